"""The independent test bed of the discovery loop (experiments/discovery_testbed).

``generators``: synthetic physics in numpy/scipy that shares no code with the library (it imports nothing
from ``hybridhyst``); ``cases``: the case list (data from the generators, the nominal a user would declare,
the split, the truth); ``run``: ``run_case``, ``run_bed`` and ``markdown`` (scoring against the truth).
``blind`` and ``blind2``: two blind beds, generators written (numpy/scipy only) by authors who had not read the
library, from a list of effects in words; ``blind_cases`` scores them as cases.
Submodules are imported on use, so that importing the generators loads nothing else.
"""
