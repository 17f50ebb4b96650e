"""Scans with exact ground truth, for testing and benchmarking: synthetic flat panels
(:mod:`.synth`), built panel meshes (:mod:`.panel`), a laser line profiler ray-casting a mesh
(:mod:`.profiler`), the truth of any mesh's holes (:mod:`.mesh_truth`) and of a scanned part
(:mod:`.scan_part`)."""
