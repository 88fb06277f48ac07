"""Linear rolling guides: ball/groove contact and lubrication (seed 001), the rolling-guide monitor, and fatigue
life (ISO 14728-1, seed 004).

* :mod:`.ball_contact`: one ball/groove contact of a four-row guide from the wear_monitor parameters, the
  ``contact rolling`` report, and ``LubricationRegimeEstimator`` for a live node. The Hertz point contact itself
  is :mod:`guide_health.models.contact.hertz_point`.
* :mod:`.carriage`: load distribution over the four ball rows of a preloaded carriage (seed 001 Eq. 1).
* :mod:`.lubrication`: Hamrock-Dowson film, lambda ratio and regime, Johnson-Greenwood-Poon load sharing with
  Greenwood-Tripp asperities.
* :mod:`.rolling_guide`: ``RollingGuideMonitor``, lubrication regime and fatigue life used from the joint and
  load samples the precision monitor accepts.
* :mod:`.rating_life`: rating life (ISO 14728-1, catalogue form), C from a life test (seed 004 Eq. 5), Miner's
  rule over a varying duty.
* :mod:`.weibull`: interval-censored failure mileages of life tests (seed 004 Sec. 3.2), Weibull maximum
  likelihood with confidence intervals.
"""
