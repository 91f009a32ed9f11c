"""Physics: the batched Newton world (``world``), the device it runs on (``device``), graph capture (``graphs``), the
step's kernels compiled ahead (``precompile``), the robot (``robot/``), the terrains (``terrain/``), the CPG's mid and
low levels (``cpg``), their float64 references (``reference``) and Newton's viewers (``viewer``). Knows nothing of
the MDP, of learning or of torch."""
