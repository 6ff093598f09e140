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
        #: the run's folder, with the outputs written before it failed (set by rftfem.run)
        self.folder = None
        where = "" if time is None else f" at t = {time:.6g} (step {step})"
        super().__init__(f"run failed{where}: {reason}")

    def __reduce__(self):  # pickles with its reason, time, step and folder
        return (type(self), (self.reason, self.time, self.step), {"folder": self.folder})


class RunInterrupted(RuntimeError):
    """The run was stopped by a signal (SIGINT, SIGTERM): exit status 128 + its
    number (130, 143); outputs written so far are kept and closed.  ``immediate``:
    a second signal stopped it inside a step, without a last output row.
    ``dropped``: the first signal came in a slow step (rftfem.integration.step_watch),
    which was dropped: the last row is the last completed step's."""

    def __init__(
        self,
        signum: int,
        time: float | None = None,
        step: int | None = None,
        immediate: bool = False,
        dropped: bool = False,
    ):
        self.signum, self.time, self.step, self.immediate = signum, time, step, immediate
        self.dropped = dropped
        super().__init__(signum)

    @property
    def exit_status(self) -> int:
        return 128 + int(self.signum)

    @property
    def signal_name(self) -> str:
        import signal

        try:
            return signal.Signals(self.signum).name
        except ValueError:
            return f"signal {self.signum}"

    def __str__(self) -> str:
        where = "" if self.time is None else f" at t = {self.time:.6g} (step {self.step})"
        how = (
            " at once (a second signal)"
            if self.immediate
            else " inside a slow step, which was dropped"
            if self.dropped
            else " after its step"
        )
        return f"run interrupted by {self.signal_name}{where}{how}"


class RunWarning(UserWarning):
    """What a run warns of (a step near a drive's period, a run not steady by its
    end), issued by the Python API's quiet runs through :mod:`warnings`; the
    warnings are also in summary.json's ``warnings``."""
