"""The robust method, in the order it runs (:func:`holecli.robust.method.detect_robust` composes them):

1. :mod:`.scene`: the scene, built once: the plane, its frame, the sensor's side (:mod:`.facing`), the
   sampling (:mod:`.sampling`: spacing h, gap g, scan lines, lattice) and the occupancy grid; it
   answers the spatial questions of every candidate;
2. :mod:`.candidates`: hole candidates, the empty regions of the grid; :mod:`.candidate`: what the
   stages learn of one of them, and how it ends (a measured hole or a refusal);
3. :mod:`.boundary`: each candidate's rim, an alpha-shape boundary of a local triangulation;
4. :mod:`.edge`: from rim points to an edge circle (the rim's envelope, a clipped fit);
5. :mod:`.acceptance`: the named checks that make a candidate a hole;
6. :mod:`.estimators`: the edge estimators, tried in this order: :mod:`.estimators.cone` (where a
   countersink's cone meets the surface), :mod:`.estimators.lattice` (brackets of a regular scan),
   :mod:`.estimators.empty_circle` (irregular sampling), :mod:`.estimators.rim_fit` (the rim fit less
   its sampling bias), each measured on synthetic holes by one harness;
7. :mod:`.surface`: the surface at one hole (its tangent plane, a curved panel's quadric);
8. :mod:`.measure`: the measurement of one candidate, stages 3-7 with their checks;
9. :mod:`.curved`: a hole on a curved panel, measured again on its flattened neighbourhood;
10. :mod:`.assemble`: from the plane frame to the world, the record's objects, with :mod:`.hole_shape`
    (below the edge), :mod:`.uncertainty` and :mod:`.doubts`; a CAD export's vertices by
    :mod:`.edge_loops`;
11. :mod:`.method`: :func:`~holecli.robust.method.detect_robust`, the conductor: the scene, every
    candidate measured, duplicates and the caller's limits, curved panels, the record.
"""
