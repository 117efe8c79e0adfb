"""The shipped simulated rig's tool transform matches how the simulator mounts its vehicle on the balance."""

import math

import numpy as np

from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE, read_rig_file
from ornitail.sim.configuration import study_configuration
from ornitail.sim.effects import EffectSet
from ornitail.sim.tunnel import true_cycle_average


def test_tool_transform_points_at_the_cg_of_the_plan_vehicle_in_body_axes():
    transform = read_rig_file(DEFAULT_RIG_FILE).tool_transform
    configuration = study_configuration("S3", 98.0)  # the vehicle of the shipped plan
    truth = true_cycle_average(configuration, EffectSet.none(), math.radians(25), 0.8, 13.5, True)
    mounting = configuration.mounting
    cg_from_sensor_body = np.array(
        [-mounting.sensor_origin_x_m, 0.0, truth.cg_station_m - mounting.sensor_origin_station_m]
    )
    expected_displacement = mounting.rotation_matrix() @ cg_from_sensor_body
    # The rig file gives the CG to 0.1 mm; a 0.5 mm error moves M by 0.5 mm x 0.1 N = 5e-5 N m, below 1/3 of a
    # typical tail moment difference of 2e-4 N m.
    np.testing.assert_allclose(transform.displacement_m, expected_displacement, atol=5e-4)
    # New axes = body axes: sensor x = x_b, sensor y = -y_b, sensor z = -z_b.
    np.testing.assert_allclose(transform.rotation, mounting.rotation_matrix().T, atol=1e-12)
