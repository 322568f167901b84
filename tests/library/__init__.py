"""Real-machine design scenes (problems/lib_*.toml) against independent numpy references."""
