"""The closed-loop keys of a scenario (docs/closed-loop-format.md): [disturbance] and [control].

The plant differs from the model the controller uses by a ``Disturbance``; ``ControlSettings``
say how often the controller acts and how far MPC looks ahead.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Disturbance:
    """How the plant differs from the model (all defaults: no disturbance).

    ``wheelbase`` maps the vehicle's length parameters (e.g. ``{"wheelbase": 5.3}``, or for a
    trailer also ``"trailer_wheelbase"``) to the plant's true values; missing ones are the model's.
    ``delay`` is a whole multiple of the sample time; ``noise`` the standard deviation on the
    measured x, y (m) and heading (rad / 10).
    """

    speed_gain: float = 1.0
    steering_bias: float = 0.0
    drift: tuple[float, float] = (0.0, 0.0)
    wheelbase: dict[str, float] = field(default_factory=dict)
    delay: float = 0.0
    noise: float = 0.0
    seed: int = 0

    @property
    def none(self) -> bool:
        """True if the plant is the model exactly (no disturbance, no delay, no noise)."""
        return self == Disturbance(seed=self.seed)


@dataclass(frozen=True)
class ControlSettings:
    """Sample time (s) of the zero-order hold and the MPC horizon (samples, or "shrinking")."""

    sample_time: float = 0.1
    horizon: int | str = 40

    def delay_samples(self, disturbance: Disturbance) -> int:
        """The actuator delay in whole samples."""
        return int(round(disturbance.delay / self.sample_time))


__all__ = ["ControlSettings", "Disturbance"]
