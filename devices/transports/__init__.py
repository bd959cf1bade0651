"""Transports: move bytes or messages, know nothing of a protocol; injected into adapters."""
