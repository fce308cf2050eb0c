"""Learning from campaigns: a campaign's attempts turned into examples (``examples``), a small
grasp-quality net (``grasp_net``) trained and scored on held-out attempts (``fit``,
``metrics``), written as an ONNX file the learned sampler loads. Torch is imported here only;
the simulator never is."""
