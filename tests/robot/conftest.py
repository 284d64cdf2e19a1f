import itertools

import pytest

from weldseam.errors import InputError
from weldseam.robot.sim import RobotSim

# 127.0.0.254 stays unused: the bad-host tests rely on nothing listening there.
_HOSTS = itertools.cycle(f"127.0.0.{n}" for n in range(10, 250))


@pytest.fixture
def robot_sim():
    """Start RobotSim(**options) on a free loopback address; stopped after the test.

    ur-rtde holds the interpreter lock while it waits, so the client must run in another process
    (the `weldseam send` CLI), never in the test process that hosts the sim.
    """
    started = []

    def start(**options) -> RobotSim:
        for _ in range(240):
            try:
                sim = RobotSim(next(_HOSTS), **options).start()
            except InputError:
                continue
            started.append(sim)
            return sim
        raise RuntimeError("no free loopback address for robot-sim")

    yield start
    for sim in started:
        sim.stop()
