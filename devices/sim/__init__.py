"""Simulated gyros that speak the real protocols over real transports, with fault injection.

Test and demonstration code: the station uses it only through ``sim+...`` device URLs.
"""
