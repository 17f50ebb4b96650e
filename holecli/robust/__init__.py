"""The robust method, in the order it runs (:func:`holecli.robust.method.detect_robust` composes them):

1. :mod:`.scene`: the scene, built once: the plane, its frame, the sensor's side (:mod:`.facing`), the
   sampling (:mod:`.sampling`: spacing h, gap g, scan lines, lattice) and the occupancy grid; it
   answers the spatial questions of every candidate;
2. :mod:`.candidates`: hole candidates, the empty regions of the grid; :mod:`.candidate`: what the
   stages learn of one of them, and how it ends (a measured hole or a refusal);
3. :mod:`.boundary`: each candidate's rim, an alpha-shape boundary of a local triangulation;
4. :mod:`.edge`: from rim points to an edge circle (the rim's envelope, a clipped fit);
5. :mod:`.acceptance`: the named checks that make a candidate a hole;
6. the edge estimators that remove the sampling's bias: :mod:`.bias` (synthetic holes),
   :mod:`.lattice` (brackets of a regular scan), :mod:`.empty_circle` (irregular sampling);
   :mod:`.countersink`: where a countersink's cone meets the surface;
7. :mod:`.surface`: the surface at one hole (its tangent plane, a curved panel's quadric);
8. :mod:`.method`: the measurement of one candidate, curved surfaces and the 3D result, with
   :mod:`.hole_shape` (below the edge), :mod:`.uncertainty` and :mod:`.doubts`; a CAD export's
   vertices by :mod:`.edge_loops`.
"""
