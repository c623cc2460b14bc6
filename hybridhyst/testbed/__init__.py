"""The independent test bed of the discovery loop (experiments/discovery_testbed).

``generators``: synthetic physics in numpy/scipy that shares no code with the library (it imports nothing
from ``hybridhyst``); ``cases``: the case list (data from the generators, the nominal a user would declare,
the split, the truth); ``run``: ``run_case``, ``run_bed`` and ``markdown`` (scoring against the truth).
Submodules are imported on use, so that importing the generators loads nothing else.
"""
