"""Visualisation: Rerun recordings of episodes and sweeps; offscreen MuJoCo renders of robots and
objects."""
