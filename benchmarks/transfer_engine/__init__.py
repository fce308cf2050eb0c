"""Pieces of ``benchmarks/transport.py``: watching the CPU and memory of each role's processes
(``process_watch``) and the broker's raw rate with bare clients (``raw_broker``)."""
