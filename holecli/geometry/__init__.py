"""Geometry shared by both methods: plane fits (:mod:`.plane`), the plane's frame (:mod:`.frame`), circle
fits (:mod:`.circle`) and small vectorised kernels (:mod:`.kernels`)."""
