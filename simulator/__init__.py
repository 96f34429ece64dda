"""Boot-motion simulator: exact truth (stance, swing, turns, stairs, running) and an MPU6050 error model.

Python API::

    from bootnav.simulator import simulate, write_h5, write_sd_txt
    res = simulate("three-floors", seed=1, profile="mpu6050-16g-2000dps", rate_hz=200.0)
    write_h5(res, "three_floors.h5")

See docs/simulator.md for the scenarios and the model equations.
"""

if __name__ != "bootnav.simulator":  # the folder simulator/ is importable only as bootnav.simulator (one module, one name)
    raise ImportError(f"import bootnav.simulator, not {__name__}: the simulator/ folder installs as bootnav.simulator")


from bootnav.simulator.gait import GAITS, Gait, PathBuilder
from bootnav.simulator.imu_model import PROFILES, SensorProfile, get_profile
from bootnav.simulator.imu_synth import MOUNTS, Mount, synthesize
from bootnav.simulator.scenarios import SCENARIOS, Scenario, custom, get_scenario
from bootnav.simulator.simulate import SimResult, simulate
from bootnav.simulator.writers import write_h5, write_sd_txt

__all__ = ["simulate", "SimResult", "write_h5", "write_sd_txt", "SCENARIOS", "Scenario", "custom", "get_scenario",
           "PROFILES", "SensorProfile", "get_profile", "MOUNTS", "Mount", "GAITS", "Gait", "PathBuilder",
           "synthesize"]
