"""Engines: ``sim`` (render, annotate, encode a scene's views) and ``transfer`` (the DataTransfer
engine over MQTT)."""
