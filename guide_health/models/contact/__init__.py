"""Elastic contact of two bodies, shared by the rolling-guide and the slewing-bearing models.

* :mod:`.elastic`: the contact modulus E* (the ONE elastic constant of every contact formula here).
* :mod:`.hertz_line`: Hertz line contact (rollers), Johnson 1985 Sec. 4.2.
* :mod:`.hertz_point`: exact elliptical Hertz point contact (balls), Johnson 1985 Sec. 4.2.
"""
