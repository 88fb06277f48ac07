"""Sliding-guide wear and precision retention (seed 000).

- :mod:`.input_rules`: what a joint, load or straightness sample must be to count (the one copy);
- :mod:`.archard`: closed forms (Eqs. 7, 10, 11, 12) and the K-free Archard integration;
- :mod:`.straightness`: minimum-zone straightness of a worn profile, stroke tracking;
- :mod:`.calibration`: K from pin-on-disc rows and from measured straightness, remaining life;
- :mod:`.gate`: the input gate of an axis (every input rule once per sample: time bases, rejections,
  recent windows, stamp gaps);
- :mod:`.guide`: the physics of one guide (Archard integration, the live effects, the K estimator);
- :mod:`.life`: remaining life, its interval, the forecast and the judgement, functions of typed inputs;
- :mod:`.axis`: an axis (its gate and its guides), the model behind the live node and offline replay;
- :mod:`.precision`: one guide on its own (a single-guide axis as one object);
- :mod:`.feed`: live inputs aligned by header stamps (the offline load rule, live), fed to an axis;
- :mod:`.effects`: the wear physics the baseline lacks (terms of the discrepancy workflow).
"""
