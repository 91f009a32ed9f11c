"""The Warp kernels of one control step that are no term table's own, each beside its float64 NumPy twin: the CPG
and the mapping of Eq. 3 and 4 with the action scaling (``cpg``; their twins in ``reference``, NumPy only, which the
deployment runtime runs), the world's (``world``) and the per-step events' (``events``). Imports nothing itself, so
that ``reference`` loads without Warp."""
