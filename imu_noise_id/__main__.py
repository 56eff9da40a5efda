"""``python -m imu_noise_id`` runs the ``imu-noise-id`` command line."""

import sys

from .cli import main

sys.exit(main())
