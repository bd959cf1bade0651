"""Gyro device adapters: codecs (pure), transports, simulated devices."""
