"""What a record says: its analysis, its grading against a profile, the settings a profile
implies."""
