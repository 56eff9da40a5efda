"""ament_python build script: installs the package, its ROS 2 resource files and executables.

The default YAML files have one copy, in config/ beside package.xml (the ament layout); they are installed as data
files into share/imu_noise_id/config/, where imu_noise_id/resources.py finds them (and, in a source or editable
checkout, in config/ itself).
"""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "imu_noise_id"
# Relative to this file's folder, where pip and colcon run setup.py.
CONFIG_FILES = sorted(glob("config/*.yaml"))
if not CONFIG_FILES:
    raise SystemExit("setup.py: config/*.yaml not found: run setup.py from the folder that holds it")

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*", "bench", "bench.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", CONFIG_FILES),
    ],
    python_requires=">=3.10",
    install_requires=["setuptools", "numpy>=1.24", "scipy>=1.10", "rosbags>=0.10", "pyyaml", "matplotlib",
                      "dask[distributed]>=2024.1", "pyarrow>=14"],
    zip_safe=False,
    maintainer="imu_noise_id developers",
    maintainer_email="dev@imu-noise-id.invalid",
    description="IMU stochastic error identification, offline and online (ROS 2).",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "imu-noise-id = imu_noise_id.cli:main",
            "imu_noise_id_node = imu_noise_id.ros.node:main",
        ],
    },
)
