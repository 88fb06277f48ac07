"""The discrepancy workflow (DESIGN.md): where the wear model and the measured straightness disagree,
which named physical effect is missing, and how much the gap shrinks once it is added.

- :mod:`.duty` reduces a machine's motion and load (a bag, streamed in chunks) to duty cells;
- :mod:`.model` evaluates the baseline and the effect terms of ``models/wear/effects/`` over them;
- :mod:`.selection` fits models, scores them (BIC and held-out forecast error) and adds effects one at a
  time while they earn their parameters; it also serves seed 000's pin-on-disc wear law;
- :mod:`.analysis` finds systematic residuals over time and against the operating conditions;
- :mod:`.workflow` ties them together (``diagnose``), :mod:`.report` writes JSON, Markdown and PNG.
"""
