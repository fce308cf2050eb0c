"""Pieces the transfer benchmarks share (``dr_ablation.py``, ``object_transfer.py``): the
training sets' recipes and the test domains' held-out sources, building a set with the real
pipeline, reading its frames as class maps, training a segmentation net, and scoring it."""
