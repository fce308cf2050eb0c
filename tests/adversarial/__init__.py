"""Fuzz tests (marker ``adversarial``): generated bad input never gives a traceback."""
