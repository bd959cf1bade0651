"""Plain data of the station: rate records, runs, run documents, profiles, benches."""
