"""Lunar foraging-with-recharging scenario (issue 22)."""
