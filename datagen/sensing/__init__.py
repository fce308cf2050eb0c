"""Sensing: what the cameras of a built scene see and what is labelled in it. Off-screen
capture (``render``), labels from the buffers (``annotate``), encoding into parts
(``encode``)."""
