"""The simulated plant (device.sim.plant): the realistic robot's parameters lie in their
documented ranges and come from the seed; its drives act a tick late and with their gain;
the ideal plant is the controller's model exactly."""

import pytest

from core.errors import ParameterError
from core.robot import RobotModel
from core.trial import THESIS_SUBJECT
from device.sim import physics
from device.sim.plant import SPREAD, Plant
from device.sim.simulator import SimulatorBackend

NOMINAL = RobotModel()
REST = (1.0, 2.0)


def within(value, name, scale=1.0):
    low, high = SPREAD[name]
    return low * scale - 1e-12 <= value <= high * scale + 1e-12


@pytest.mark.parametrize("seed", range(5))
def test_every_realistic_parameter_lies_in_its_documented_range(seed):
    plant = Plant.realistic(NOMINAL, seed, REST)
    r = plant.robot
    for link, nominal in zip(r.links, NOMINAL.links, strict=True):
        assert within(link.mass_kg, "link_mass_scale", nominal.mass_kg)
        assert within(link.inertia_kgm2, "link_inertia_scale", nominal.inertia_kgm2)
    for i in range(2):
        assert within(r.friction.joint_coulomb_Nm[i], "joint_coulomb_scale",
                      NOMINAL.friction.joint_coulomb_Nm[i])
        assert within(r.friction.joint_viscous_Nms[i], "joint_viscous_scale",
                      NOMINAL.friction.joint_viscous_Nms[i])
        assert within(plant.torque_gain[i], "drive_gain")
    assert within(r.friction.ee_coulomb_N, "handle_coulomb_N")
    assert within(r.stiffness.k11_Nm_rad, "joint_stiffness_Nm_rad")
    assert (r.stiffness.q1_rest_rad, r.stiffness.q2_rest_rad) == REST
    assert plant.actuator_delay
    assert r.l2_m == NOMINAL.l2_m  # the geometry is the model's: the encoders read it


def test_the_plant_is_drawn_by_the_seed():
    assert Plant.realistic(NOMINAL, 3, REST) == Plant.realistic(NOMINAL, 3, REST)
    assert Plant.realistic(NOMINAL, 3, REST) != Plant.realistic(NOMINAL, 4, REST)
    assert Plant.of_kind("ideal", NOMINAL, 3, REST).robot == NOMINAL


@pytest.mark.parametrize("kind", ["perfect", "", None])
def test_an_unknown_plant_is_refused_by_name(kind):
    with pytest.raises(ParameterError, match="plant"):
        Plant.of_kind(kind, NOMINAL, 0, REST)


def test_the_drives_act_one_write_late_and_with_their_gain():
    sim = SimulatorBackend.from_trial(THESIS_SUBJECT, plant="realistic", seed=1,
                                      compiled=False)
    gain = sim.plant.torque_gain
    sim.open()
    sim.write(1.0, -0.5)
    assert (sim.state[physics.X_TAU1], sim.state[physics.X_TAU2]) == (0.0, 0.0)
    sim.write(0.2, 0.3)
    assert sim.state[physics.X_TAU1] == pytest.approx(gain[0] * 1.0)
    assert sim.state[physics.X_TAU2] == pytest.approx(gain[1] * -0.5)
    sim.safe_state()
    sim.write(0.0, 0.0)
    assert (sim.state[physics.X_TAU1], sim.state[physics.X_TAU2]) == (0.0, 0.0)
    ideal = SimulatorBackend.from_trial(THESIS_SUBJECT, plant="ideal", compiled=False)
    ideal.open()
    ideal.write(1.0, -0.5)
    assert (ideal.state[physics.X_TAU1], ideal.state[physics.X_TAU2]) == (1.0, -0.5)


def test_a_second_robot_beside_a_plant_is_refused():
    patient = SimulatorBackend.from_trial(THESIS_SUBJECT).patient
    with pytest.raises(ParameterError, match="robot"):
        SimulatorBackend(patient, robot=RobotModel(l1_m=0.11), plant=Plant.ideal(NOMINAL))


def test_every_trial_runs_on_the_same_simulated_robot_whatever_its_seed():
    """A new seed per trial (issue 27 #16) drew a new robot per trial too: each trial's
    masses, friction and drives differed, so the console's simulated station had no one
    robot (a learned model of 'its' trials mixed robots). The trial's seed draws the
    patient and the noise; the robot is drawn by its own seed, the same for every trial."""
    from device.loop.backends import make_backend
    from device.loop.messages import BackendConfig
    from device.loop.pipeline import TrialPlan

    plan = TrialPlan.build(THESIS_SUBJECT)
    robots = {make_backend(BackendConfig(patient="tremor", seed=seed), THESIS_SUBJECT, plan,
                           compiled=False).plant for seed in (1, 2, 3)}
    assert len(robots) == 1
    tremors = {make_backend(BackendConfig(patient="tremor", seed=seed), THESIS_SUBJECT,
                            plan, compiled=False).patient.parameters.tremor
               for seed in (1, 2, 3)}
    assert len(tremors) == 3  # the patient still varies from trial to trial
    another = make_backend(BackendConfig(seed=1, robot_seed=7), THESIS_SUBJECT, plan,
                           compiled=False).plant
    assert another != robots.pop()  # another station's robot is asked for by its own seed
