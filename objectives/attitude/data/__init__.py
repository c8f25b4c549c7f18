"""Recordings (IMU data with ground truth): the container, loaders and synthetic test benches.

Modules, one job each:

- :mod:`.recording`: the :class:`Recording` container and its validation.
- :mod:`.loaders`, :mod:`.broad`, :mod:`.csv`: reading recordings from YAML specs, BROAD files and CSV.
- :mod:`.csv_table`, :mod:`.timebase`, :mod:`.alignment`: another lab's CSV: its layout; its stamps,
  sample-and-hold, resampling and truth sanity; the alignment of its truth to the IMU (lag, body, heading).
- :mod:`.lablog`: another lab's log synthesised with known defects (tests, the README example).
- :mod:`.imu_model`: the sensor model (FAEKF paper eqs. 7 and 9); :mod:`.magnetic`: the magnetic
  perturbation generator (eq. 34).
- :mod:`.bench_common`, :mod:`.bench6dof`, :mod:`.tilt1d`: the synthetic benches.
- :mod:`.cache`: synthetic recordings by generator name, cached in memory and on disk;
  :mod:`.export_csv`: CSV export.
- :mod:`.synthetic`: one import for the sensor model, the benches, the cache and the export.
"""

from objectives.attitude.data.recording import Recording, RecordingError

__all__ = ["Recording", "RecordingError"]
