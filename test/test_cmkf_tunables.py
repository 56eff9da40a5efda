"""The CMKF's tunables are declared once (``CMKF_TUNABLES``): the node's parameters, the options of
``imu-noise-id cmkf`` and the node's ``CmkfConfig`` are made from them; ``OnlineConfig`` has a declared field per
parameter."""

from __future__ import annotations

import dataclasses

import pytest

from imu_noise_id.cli import build_parser
from imu_noise_id.cli.cmkf import OPTIONS
from imu_noise_id.core.cmkf.config import CmkfConfig
from imu_noise_id.core.errors import InputError
from imu_noise_id.pipelines.online.config import (
    CMKF_TUNABLES,
    PARAMETER_BY_NAME,
    PARAMETERS,
    OnlineConfig,
    cmkf_config,
)


def test_every_tunable_is_a_cmkf_field_with_its_type_and_default_in_the_node_and_the_cli():
    fields = {f.name for f in dataclasses.fields(CmkfConfig)}
    args = build_parser().parse_args(["cmkf", "bag"])
    for t in CMKF_TUNABLES:
        assert t.field in fields
        if t.parameter is not None:
            spec = PARAMETER_BY_NAME[t.name]
            assert type(spec.default) is t.kind and spec.description == t.description, t.name
            assert spec.default == (t.node_default if t.node_default is not None else t.default or 0), t.name
        if t.option:
            assert getattr(args, t.field) == getattr(CmkfConfig(), t.field), t.field
    assert {t.field for t in OPTIONS} == {"measurement", "velocity_noise_std", "position_noise_std",
                                          "angular_velocity_noise_std", "accel_bias_tau", "accel_bias_sigma",
                                          "s_v0", "gyro_bias_tau", "gyro_bias_sigma"}
    # typed as the field: an int for an int field is refused by argparse, a string for a float too
    with pytest.raises(SystemExit):
        build_parser().parse_args(["cmkf", "bag", "--accel-bias-tau", "long"])


def test_the_node_config_is_every_parameter_as_a_declared_field():
    config = OnlineConfig({"cmkf.velocity_noise_std": 0.2, "nis.window": 60, "cmkf.input_latency": 0.3})
    assert [f.name for f in dataclasses.fields(OnlineConfig)] == [p.attr for p in PARAMETERS]
    assert config.values == {**{p.name: p.default for p in PARAMETERS}, "cmkf.velocity_noise_std": 0.2,
                             "nis.window": 60, "cmkf.input_latency": 0.3}
    assert cmkf_config(config) == dataclasses.replace(CmkfConfig(), velocity_noise_std=0.2, nis_window=60,
                                                      late_odom_tolerance=0.3)
    assert config == OnlineConfig(config.values) and config.updated({"gap_factor": 3}).gap_factor == 3.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.gap_factor = 2.0
    with pytest.raises(InputError, match="cannot change at runtime"):
        config.updated({"cmkf.s_v0": 1e-3})
