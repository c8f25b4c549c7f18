"""Recordings (IMU data with ground truth): the container, loaders and synthetic test benches."""

from objectives.attitude.data.recording import Recording, RecordingError

__all__ = ["Recording", "RecordingError"]
