"""Run the PI of pi.py against a running plant with PlantClient, unchanged from offline.

    hydrohil plant --scenario examples/fig11_p_control.toml --log plant-out &   # the real-time plant
    python examples/controllers/run_against_plant.py                            # this controller
"""

from hydrohil.control import measurement
from hydrohil.hil.controller import PlantClient
from hydrohil.simulation.scenario import Table

from pi import PI

reference = Table([0.0, 0.5, 1.5, 3.0, 4.0, 6.0], [0.03, 0.03, 0.15, 0.15, 0.03, 0.03])
controller = PI(kp=50.0, ki=500.0)
with PlantClient(("127.0.0.1", 47000), connect_timeout=30.0) as plant:
    for s in plant.sensors():                            # one sensor packet per plant step
        x_ref, slope = reference.at(s.t_sim)
        plant.send(controller(measurement(s, x_ref, slope, count=1e-6)), answer=s)
print(f"{plant.received} sensor packets answered")
