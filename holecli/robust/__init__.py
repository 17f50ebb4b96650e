"""The robust method, in the order it runs (:func:`holecli.robust.method.detect_robust` composes them):

1. :mod:`.sampling`: how the surface was sampled (spacing h, gap g, scan lines, lattice);
2. :mod:`.candidates`: hole candidates, the empty regions of an occupancy grid;
3. :mod:`.boundary`: each candidate's rim, an alpha-shape boundary of a local triangulation;
4. :mod:`.edge`: from rim points to an edge circle (the rim's envelope, a clipped fit);
5. :mod:`.estimators`: the edge estimators, tried in this order: :mod:`.estimators.cone` (where a
   countersink's cone meets the surface), :mod:`.estimators.lattice` (brackets of a regular scan),
   :mod:`.estimators.empty_circle` (irregular sampling), :mod:`.estimators.rim_fit` (the rim fit less
   its sampling bias), each measured on synthetic holes by one harness;
6. :mod:`.hole_shape`, :mod:`.uncertainty`, :mod:`.doubts`: the hole below its edge, the
   uncertainties, the warnings;
7. :mod:`.method`: the scene, the acceptance checks, curved surfaces and the 3D result.
"""
