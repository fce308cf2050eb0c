"""A grasp-quality model's contract: what it sees of one candidate (``inputs``) and the file
that holds it (``model_file``). Pure numpy, OpenCV and onnxruntime: no simulator, no torch, so
the config check, the learned sampler and the training code share one definition."""
