"""Simulator-side work on a built scene: off-screen capture (``render``), labels from the buffers
(``annotate``), encoding into parts (``encode``)."""
