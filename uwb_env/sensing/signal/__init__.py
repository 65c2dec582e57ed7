"""Signal-level fidelity: synthesised impulse scans (seed 000's chains) and chirp pulse trains (seed 003's chain)."""

from uwb_env.sensing.signal.chirp_sensor import ChirpEpisode, ChirpSignalSensor, PairTrace
from uwb_env.sensing.signal.sensor import ScanTrace, SignalEpisode, SignalSensor

__all__ = ["ChirpEpisode", "ChirpSignalSensor", "PairTrace", "ScanTrace", "SignalEpisode", "SignalSensor"]
