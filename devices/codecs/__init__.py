"""Pure codecs: bytes in, decoded frames plus the unconsumed rest out; encoders invert them.

Nothing here opens a port or keeps state between calls: a codec object holds only its
configuration (datagram identifier, layout, units).
"""
