"""The search for the worlds where a stack fails: generate-and-test over the WorldSpec space, a
candidate's fitness from its repeated runs (docs/search.md).

``spec`` (the validated search spec), ``space`` (points of the box [0, 1]^d to candidate worlds),
``algorithms`` (random, MAP-Elites, CMA-ME, GA, NSGA-II behind one ask/tell protocol),
``presets`` (the ready specs of ``navstress search init``), ``objectives`` (fitness, confirmation,
descriptors), ``figures`` (the report's pictures). Nothing is imported here: the algorithms'
libraries take seconds to load.
"""
