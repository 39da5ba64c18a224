"""Control layer: turning plans and policies into trap commands."""
