"""The robust method, in the order it runs (:func:`holecli.robust.method.detect_robust` composes them):

1. :mod:`.sampling`: how the surface was sampled (spacing h, gap g, scan lines, lattice);
2. :mod:`.candidates`: hole candidates, the empty regions of an occupancy grid;
3. :mod:`.boundary`: each candidate's rim, an alpha-shape boundary of a local triangulation;
4. :mod:`.edge`: from rim points to an edge circle (the rim's envelope, a clipped fit);
5. the edge estimators that remove the sampling's bias: :mod:`.bias` (synthetic holes),
   :mod:`.lattice` (brackets of a regular scan), :mod:`.empty_circle` (irregular sampling);
6. :mod:`.countersink`: where a countersink's cone meets the surface;
7. :mod:`.method`: the scene, the acceptance checks, curved surfaces and the 3D result.
"""
