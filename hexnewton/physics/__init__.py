"""Physics: the batched Newton world (``world``), the device it runs on (``device``), graph capture (``graphs``), the
step's kernels compiled ahead (``precompile``), the scene's model (``model_build``) and Newton's viewers (``viewer``).
The robot (``hexnewton.robot``), the terrains (``hexnewton.terrain``) and the step's kernels (``hexnewton.kernels``)
sit beside it at the same level. Knows nothing of the MDP, of learning or of torch."""
