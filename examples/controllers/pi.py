"""A PI position controller in plain Python, for `[controller] type = "python"` (fig11_python_pi.toml)."""


class PI:
    """ū = kp·e + ki·∫e dt, the integral frozen while the command is saturated (anti-windup)."""

    def __init__(self, kp=50.0, ki=500.0):
        self.kp, self.ki, self.integral, self.t = kp, ki, 0.0, None

    def __call__(self, m):                    # m: hydrohil.control.Measurement (t, x_ref, x, p1, ...)
        e = m.x_ref - m.x
        dt = 0.0 if self.t is None else m.t - self.t
        self.t = m.t
        u = self.kp * e + self.integral
        if abs(u) < 1.0:
            self.integral += self.ki * e * dt
        return max(-1.0, min(1.0, u))
