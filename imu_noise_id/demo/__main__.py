"""``python -m imu_noise_id.demo``: run the demo (:func:`imu_noise_id.demo.main`)."""

import sys

from . import main

sys.exit(main())
