"""Server parameters of the half-field soccer simulator.

Every constant carries the name rcssserver gives it (``server.conf`` of HFO's server fork,
protocol v15 era), so that a reader who knows the server can check them line by line.
See SPEC §3. Field geometry constants follow HFO's half-field layout.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

__all__ = ["DEFAULT_PARAMS", "ServerParams"]


@dataclass(frozen=True)
class ServerParams:
    """One record of every physical constant the simulator uses (rcssserver names).

    Noise is switched off with :meth:`without_noise`, which zeroes ``ball_rand``,
    ``player_rand`` and ``kick_rand`` (``player_rand`` also drives the turn noise, as in the
    server).
    """

    # --- objects -----------------------------------------------------------------------------
    ball_size: float = 0.085
    ball_decay: float = 0.94
    ball_rand: float = 0.05
    ball_speed_max: float = 3.0
    ball_accel_max: float = 2.7

    player_size: float = 0.3
    player_decay: float = 0.4
    player_rand: float = 0.1
    player_speed_max: float = 1.05
    player_accel_max: float = 1.0
    inertia_moment: float = 5.0

    # --- commands ----------------------------------------------------------------------------
    kick_power_rate: float = 0.027
    dash_power_rate: float = 0.006
    kickable_margin: float = 0.7
    kick_rand: float = 0.1
    kickable_buffer: float = 0.055
    """librcsc's margin on the kickable test (``SelfObject::updateBallInfo``, ball seen this
    cycle): an HFO agent's kickable feature is on, and librcsc sends a kick at all, only when the
    ball is within ``kickable_area - 0.055 = 1.03``. 0 restores the server's bare test (1.085)."""
    maxpower: float = 100.0
    minpower: float = -100.0
    maxmoment: float = 180.0
    minmoment: float = -180.0
    max_dash_angle: float = 180.0
    min_dash_angle: float = -180.0
    dash_angle_step: float = 45.0
    side_dash_rate: float = 0.4
    back_dash_rate: float = 0.6

    # --- stamina model -----------------------------------------------------------------------
    stamina_max: float = 8000.0
    stamina_inc_max: float = 45.0
    effort_max: float = 1.0
    effort_min: float = 0.6
    effort_dec_thr: float = 0.3
    effort_dec: float = 0.005
    effort_inc_thr: float = 0.6
    effort_inc: float = 0.01
    recover_max: float = 1.0
    recover_min: float = 0.5
    recover_dec_thr: float = 0.3
    recover_dec: float = 0.002

    # --- field (HFO half field) ----------------------------------------------------------------
    pitch_length: float = 105.0
    pitch_width: float = 68.0
    pitch_margin: float = 5.0
    goal_width: float = 14.02
    goal_post_radius: float = 0.06
    penalty_area_length: float = 16.5
    penalty_area_width: float = 40.32

    # --- HFO referee and reset ---------------------------------------------------------------
    goal_line_x: float = 52.585
    """x the ball must cross to score (52.5 + ball_size)."""
    goal_half_width: float = 7.07
    """|y| bound for a goal at the goal line (HFO's check)."""
    reset_y_limit: float = 27.2
    """|y| limit for ball and player placement at reset (HFO: 0.8 * 34)."""
    reset_player_spread: float = 10.5
    """Offense players are placed at ball + spread * (U(0,1) + offset) (HFO)."""

    # --- observation normalisation (HFO low-level features, 2016) -------------------------
    max_dist: float = 62.55
    """Normaliser of proximities, sqrt(52.5**2 + 34**2)."""
    observed_self_speed_max: float = 0.46
    observed_ball_speed_max: float = 5.0
    observed_player_speed_max: float = 0.75

    @property
    def kickable_area(self) -> float:
        """Largest centre distance at which a player can kick: 0.3 + 0.7 + 0.085 = 1.085."""
        return self.player_size + self.kickable_margin + self.ball_size

    @property
    def client_kickable_area(self) -> float:
        """Largest distance at which an HFO agent can kick (librcsc): 1.085 - 0.055 = 1.03."""
        return self.kickable_area - self.kickable_buffer

    @property
    def goal_post_x(self) -> float:
        """x of the goal posts' centres as the server places them: 52.5 - 0.06 = 52.44."""
        return self.half_length - self.goal_post_radius

    @property
    def goal_post_y(self) -> float:
        """|y| of the goal posts' centres as the server places them: 7.01 + 0.06 = 7.07."""
        return 0.5 * self.goal_width + self.goal_post_radius

    @property
    def half_length(self) -> float:
        """x of the goal line (52.5)."""
        return self.pitch_length / 2.0

    @property
    def half_width(self) -> float:
        """|y| of the touch lines (34)."""
        return self.pitch_width / 2.0

    def without_noise(self) -> ServerParams:
        """A copy with every random perturbation switched off (for exact tests)."""
        return dataclasses.replace(self, ball_rand=0.0, player_rand=0.0, kick_rand=0.0)

    def replace(self, **changes: float) -> ServerParams:
        """A copy with the named constants changed; unknown names raise ``TypeError``."""
        return dataclasses.replace(self, **changes)


DEFAULT_PARAMS = ServerParams()
"""The server's defaults, noise on."""
