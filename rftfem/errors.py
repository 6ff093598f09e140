"""The two ways a run ends early, each with its own exit status (docs/scenes.md,
"Command line")."""


class SceneError(ValueError):
    """Bad scene or bad option: exit status 2, one line naming the key path."""

    exit_status = 2


class RunFailed(RuntimeError):
    """The run failed numerically: exit status 3; outputs written so far are kept."""

    exit_status = 3

    def __init__(self, reason: str, time: float | None = None, step: int | None = None):
        self.reason, self.time, self.step = reason, time, step
        where = "" if time is None else f" at t = {time:.6g} (step {step})"
        super().__init__(f"run failed{where}: {reason}")
