"""ament_python build script: installs the package, its ROS 2 resource files and executables."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "imu_noise_id"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*", "bench", "bench.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob(f"{PACKAGE}/config/*.yaml")),
    ],
    package_data={PACKAGE: ["config/*.yaml"]},
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
