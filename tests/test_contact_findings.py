"""docs/findings.md's contact headline numbers by routes of their own: bare engine loops written
here and closed forms, never the harness's measure. (The friction cone's, the turning scenes' and
each engine's own figures are reproduced beside their poses, in tests/test_contact_<engine>.py; the
penalty table's in tests/test_penalty.py.)

Tolerances: the first bounce's restitution to 1e-3 (it is a deterministic run of one engine release);
the closed form to 1e-12."""

from __future__ import annotations

import math

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

#: The stiff common pose's contact frequency (adapters/mujoco/contact.py's OMEGA_C, stated here).
OMEGA_C = 200.0


def first_bounce(integrator: str, dt: float = 1e-3) -> float:
    """sqrt(H1 / H0) of a 0.1 m ball dropped from 1 m onto MuJoCo's stiff undamped contact
    (solref (-omega_c^2, 0), constant impedance 0.9999) on one slide joint."""
    k = -(OMEGA_C**2)
    imp = 'solimp="0.9999 0.9999 0.001 0.5 2"'
    xml = f"""<mujoco><option timestep="{dt}" integrator="{integrator}" gravity="0 0 -9.81"/>
    <worldbody><geom type="plane" size="0 0 1" condim="1" solref="{k} 0" {imp} margin="0" gap="0"/>
    <body><joint type="slide" axis="0 0 1"/>
    <geom type="sphere" size="0.1" mass="1" condim="1" solref="{k} 0" {imp}/></body></worldbody>
    <keyframe><key qpos="1.1"/></keyframe></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    z, v = [], []
    for _ in range(2500):
        mujoco.mj_step(m, d)
        z.append(d.qpos[0] - 0.1)
        v.append(d.qvel[0])
    z, v = np.array(z), np.array(v)
    i = int(np.argmax(z < 0.0))  # the impact
    j = i + int(np.argmax(v[i:] > 0.0))  # leaving it
    k_ = j + int(np.argmax(v[j:] < 0.0))  # the apex after it
    return math.sqrt(float(np.max(z[j:k_])) / 1.0)


def test_mujocos_discrete_step_keeps_three_quarters_of_an_elastic_bounce_at_1_ms_and_euler_all_of_it():
    assert first_bounce("discrete") == pytest.approx(0.759, abs=1e-3)
    assert first_bounce("Euler") == pytest.approx(1.004, abs=1e-3)


def test_implicit_euler_keeps_0_732_of_one_impact_at_the_same_h_omega_c():
    hw = 1e-3 * OMEGA_C
    assert (1.0 + hw * hw) ** (-math.pi / (2.0 * math.atan(hw))) == pytest.approx(0.7319061167321093, rel=1e-12)
