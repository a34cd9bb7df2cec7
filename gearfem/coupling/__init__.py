"""Coupling between the cycle and the thermal model: the heat sources of the contact cycle (the
split between the gears, the transfer to the thermal mesh)."""
