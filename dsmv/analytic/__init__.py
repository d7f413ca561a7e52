"""Closed-form models: the energy method (bearing capacity, Hansbo, Bekker to come)."""
