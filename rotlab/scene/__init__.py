"""Scene: a validated scenario turned into numbers — principal axes, loads as torque terms,
the scene's kind and its invariants."""
