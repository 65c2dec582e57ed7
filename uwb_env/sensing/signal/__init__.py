"""Signal-level fidelity: synthesised UWB impulse scans through the detection and localization chains."""

from uwb_env.sensing.signal.sensor import ScanTrace, SignalEpisode, SignalSensor

__all__ = ["ScanTrace", "SignalEpisode", "SignalSensor"]
