"""Pure numerics of the gyro station: Allan variance, DAVAR, noise fits, simulation models.

Nothing here does I/O, prints, or keeps global state: numpy arrays and small frozen
dataclasses in, results out.
"""
