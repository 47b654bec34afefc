"""Other traffic in Eclipse SUMO (docs/traffic-format.md): the network, the co-simulation loop, the runs.

A layer above ``model.simulation`` and below ``model.cli``: ``network`` writes the scenario's
roundabout as a SUMO network and its flows as routes, ``cosim`` drives SUMO through TraCI (the
``sumo`` driver, the contract's replay loop), ``run`` scores a run on exact rectangles and writes
its files.
"""
