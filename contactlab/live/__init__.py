"""Live recognition: the observer of 6.4 on a running source (``contactlab watch``).

- :mod:`.conditioner` :class:`LiveConditioner`, the causal chunk-consistent form of
  :func:`contactlab.signals.trial_signals`
- :mod:`.sources`     live sources: the simulator in real time, Net F/T, PHANToM, CSV lines
- :mod:`.watch`       :class:`Watcher`: conditioning, the observer, the JSON lines, the
  recording
"""

from contactlab.live.conditioner import LiveConditioner

__all__ = ["LiveConditioner"]
