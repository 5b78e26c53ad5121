"""`selfmanip.motor.operating_point`: the drive's optional losses through the binding — the
default law against Table 2.2's derived row, the power-flow gearbox loss against the
derating (a factor 1/η² when back-driven), the battery against its own energy identity, and
bad options as errors naming the field."""

from __future__ import annotations

import pytest

from selfmanip import motor
from selfmanip.errors import InvalidInputError

NO_LIMIT_A = 1e6  # the unclipped torque-speed line


def _row(name: str = "x-rhex-28") -> dict:
    return next(r for r in motor.drive_table(current_limit_a=NO_LIMIT_A) if r["name"] == name)


@pytest.mark.parametrize("command, speed", [(1.0, 0.0), (1.0, 10.0), (0.5, 5.0), (-0.8, -2.0)])
def test_default_operating_point_is_the_tables_torque_speed_line(command, speed):
    # G η τ_stall (u − ω/ω₀,out), with G η τ_stall and ω₀,out from the drive table
    row = _row()
    p = motor.operating_point("x-rhex-28", command, speed, current_limit_a=NO_LIMIT_A)
    line = row["achievable_output_stall_torque_n_m"] * (command - speed / row["output_no_load_speed_rad_s"])
    assert p["output_torque_n_m"] == pytest.approx(line, rel=1e-12)
    assert p["battery_voltage_v"] == row["supply_voltage_v"]


def test_power_flow_loss_brakes_harder_by_one_over_eta_squared_when_back_driven():
    eta = _row()["efficiency"]
    for command, speed, factor in [(1.0, -3.0, 1 / eta**2), (0.3, 20.0, 1 / eta**2), (1.0, 10.0, 1.0)]:
        derating = motor.operating_point("x-rhex-28", command, speed)["output_torque_n_m"]
        flow = motor.operating_point("x-rhex-28", command, speed, gearbox_loss="power_flow")["output_torque_n_m"]
        assert flow == pytest.approx(factor * derating, rel=1e-12), (command, speed)


def test_battery_power_is_open_circuit_voltage_times_battery_current_and_sags_the_stall_torque():
    row = _row()
    v_oc = row["supply_voltage_v"]
    ideal = motor.operating_point("x-rhex-28", 1.0, 0.0, current_limit_a=NO_LIMIT_A)
    for r_b in (0.1, 0.5):
        for command, speed in [(1.0, 0.0), (0.6, 8.0), (-0.5, 3.0)]:
            p = motor.operating_point("x-rhex-28", command, speed, battery_resistance_ohm=r_b,
                                      current_limit_a=NO_LIMIT_A)
            # the power drawn from V_oc is V_oc I_b; the terminal voltage is V_oc − R_b I_b
            assert p["electrical_power_w"] == pytest.approx(v_oc * p["battery_current_a"], rel=1e-12)
            assert p["battery_voltage_v"] == pytest.approx(v_oc - r_b * p["battery_current_a"], rel=1e-14)
            # a lossless PWM stage: the battery current is the duty times the winding current
            assert p["battery_current_a"] == pytest.approx(command * p["current_a"], rel=1e-10)
        # stall: the winding current V_oc/(R + R_b), with R = V_oc / (ideal stall current)
        stall = motor.operating_point("x-rhex-28", 1.0, 0.0, battery_resistance_ohm=r_b, current_limit_a=NO_LIMIT_A)
        r = v_oc / ideal["current_a"]
        assert stall["current_a"] == pytest.approx(v_oc / (r + r_b), rel=1e-12)


@pytest.mark.parametrize("kwargs, field", [
    ({"gearbox_loss": "lossy"}, "gearbox_loss"),
    ({"battery_resistance_ohm": -0.1}, "battery_resistance_ohm"),
    ({"battery_resistance_ohm": float("nan")}, "battery_resistance_ohm"),
])
def test_bad_loss_options_name_the_field(kwargs, field):
    with pytest.raises(InvalidInputError) as e:
        motor.operating_point("x-rhex-28", 1.0, 0.0, **kwargs)
    assert e.value.field == field
