"""The closed loop: a disturbed plant, controllers, and the loop that joins them.

``plant.py`` integrates the scenario's own vehicle model with the disturbances of
docs/closed-loop-format.md; ``controllers.py`` holds the open-loop replay and the tracking
controller; ``mpc.py`` the NMPC; ``loop.py`` runs a controller against the plant. Every
controller follows ``base.Controller``.
"""
