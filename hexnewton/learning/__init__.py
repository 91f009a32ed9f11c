"""Learning on top of the MDP: the agent's configuration (``agent``), the rsl-rl runner (``runner``), checkpoints
(``checkpoint``), policies and their ONNX export (``policy``), the skrl baselines (``baselines``) and the stop
signals both trainers share (``stopping``)."""
