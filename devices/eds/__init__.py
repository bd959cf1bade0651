"""EDS files of the CANopen devices the station ships (package data)."""
