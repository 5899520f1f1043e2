# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The store on its aft hinge in MuJoCo, built from an inline MJCF string and stepped 1,501 times.

The peer of ``cfem-sim run config/store_separation.yaml`` in
``bench_startup.py``: the same store (907.2 kg, pitch hinge 0.3292 m aft of
and 0.25 m above the CG, gravity +z, RK4 at dt = 1 ms), as a whole process.
It records nothing and prints the final pitch angle.
"""

import mujoco

MJCF = """
<mujoco model="store_separation">
  <option timestep="0.001" integrator="RK4" gravity="0 0 9.80665"/>
  <worldbody>
    <body name="store" pos="0 0 0">
      <inertial pos="0 0 0" mass="907.1848" diaginertia="27.1164 488.0944 488.0944"/>
      <joint name="pivot" type="hinge" axis="0 1 0" pos="-0.3292 0 -0.25"/>
    </body>
  </worldbody>
</mujoco>
"""


def main():
    """Build the model, step it 1,501 times and print the hinge angle."""
    model = mujoco.MjModel.from_xml_string(MJCF)
    data = mujoco.MjData(model)
    for _ in range(1501):
        mujoco.mj_step(model, data)
    print(f'pitch {data.qpos[0]:.6f} rad at t = {data.time:.3f} s')


if __name__ == '__main__':
    main()
