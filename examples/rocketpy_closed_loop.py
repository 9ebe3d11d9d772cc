"""Fly this project's flight computer inside your own RocketPy simulation (closed loop).

RocketPy's "Calisto" getting-started rocket (Cesaroni M1670, 127 mm), with its "apogee" and
"800 m" parachute triggers replaced by the board's exact decision code (shared/): the drogue opens
when our firmware fires it, the main when it fires the main. Run from the repository root:

    .venv/bin/python examples/rocketpy_closed_loop.py [--seed 1] [--csv what_the_board_saw.csv]

See docs/SIMULATION.md ("Our firmware inside RocketPy").
"""

import argparse
import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rocketpy import Environment, Flight, Rocket, SolidMotor  # noqa: E402

from desktop.sim.rocketpy_trigger import FlightComputerTrigger, add_board_sensors  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=1, help="sensor noise and offsets (default 1)")
    ap.add_argument("--csv", help="write the readings the board used as a flight CSV")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")  # RocketPy's "Sensor class is experimental" warnings

    env = Environment(latitude=32.990254, longitude=-106.974998, elevation=1400)
    env.set_atmospheric_model(type="standard_atmosphere")
    motor = SolidMotor(
        thrust_source=str(ROOT / "examples" / "motors" / "Cesaroni_M1670.eng"),
        dry_mass=1.815, dry_inertia=(0.125, 0.125, 0.002), nozzle_radius=33 / 1000, grain_number=5,
        grain_density=1815, grain_outer_radius=33 / 1000, grain_initial_inner_radius=15 / 1000,
        grain_initial_height=120 / 1000, grain_separation=5 / 1000, grains_center_of_mass_position=0.397,
        center_of_dry_mass_position=0.317, nozzle_position=0, burn_time=3.9, throat_radius=11 / 1000,
        coordinate_system_orientation="nozzle_to_combustion_chamber",
    )
    rocket = Rocket(radius=127 / 2000, mass=14.426, inertia=(6.321, 6.321, 0.034), power_off_drag=0.5,
                    power_on_drag=0.5, center_of_mass_without_motor=0,
                    coordinate_system_orientation="tail_to_nose")
    rocket.add_motor(motor, position=-1.255)
    rocket.add_nose(length=0.55829, kind="vonKarman", position=1.278)
    rocket.add_trapezoidal_fins(n=4, root_chord=0.120, tip_chord=0.060, span=0.110, position=-1.04956)
    rocket.add_tail(top_radius=0.0635, bottom_radius=0.0435, length=0.060, position=-1.194656)

    # The board: a BMP388 barometer and an ADXL375 accelerometer read at 100 Hz (figures from the
    # project's part profiles), and the flight computer with its configuration (docs/CONFIG.md).
    baro, accel = add_board_sensors(rocket, "bmp388+adxl375", rate_hz=100, seed=args.seed)
    fc = FlightComputerTrigger(baro, accel, config={"main_deploy_m": 250})
    rocket.add_parachute("drogue", cd_s=1.0, trigger=fc.drogue, sampling_rate=100, lag=1.5)
    rocket.add_parachute("main", cd_s=10.0, trigger=fc.main, sampling_rate=100, lag=1.5)

    # time_overshoot=False: RocketPy stops at every sample, measures the sensors, then asks the
    # triggers, so the drogue is triggered at the very sample of the board's decision. RocketPy's
    # default (True) is 4 to 5 times faster, but acts one sample late and, in RocketPy 1.13, skips
    # the samples of the solver step that contains the apogee.
    flight = Flight(rocket=rocket, environment=env, rail_length=5.2, inclination=85, heading=0,
                    time_overshoot=False)
    fc.finish()  # step the readings measured after the last trigger call

    print(f"RocketPy apogee {flight.apogee - env.elevation:.1f} m AGL at {flight.apogee_time:.3f} s")
    for e in fc.events:
        print(f"  flight computer: {e.event:8s} at {e.time_s:8.3f} s, filtered altitude "
              f"{e.altitude_m:7.1f} m")
    for t, chute in flight.parachute_events:
        print(f"  RocketPy: {chute.name} triggered at {t:.3f} s (opens {chute.lag:g} s later), "
              f"true altitude {flight.z(t) - env.elevation:.1f} m")
    print(f"  landed at {flight.t_final:.1f} s, {fc.steps} samples stepped")
    if args.csv:
        fc.write_csv(args.csv)
        print(f"wrote {args.csv}: replay it with python -m desktop replay {args.csv}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
