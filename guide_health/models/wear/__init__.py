"""Sliding-guide wear and precision retention (seed 000).

- :mod:`.input_rules`: what a joint, load or straightness sample must be to count (the one copy);
- :mod:`.archard`: closed forms (Eqs. 7, 10, 11, 12) and the K-free Archard integration;
- :mod:`.straightness`: minimum-zone straightness of a worn profile, stroke tracking;
- :mod:`.calibration`: K from pin-on-disc rows and from measured straightness, remaining life;
- :mod:`.precision`: the precision monitor behind the live node and offline replay;
- :mod:`.feed`: live inputs aligned by header stamps (the offline load rule, live);
- :mod:`.effects`: the wear physics the baseline lacks (terms of the discrepancy workflow).
"""
