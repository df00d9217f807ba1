"""EMG in place of the force sensor, in closed loop (thesis chapter 5's cHRI aim): a
synthetic subject's trials recorded with the motors giving no help, an EMG-to-torque model
trained on them as the live console will feed it and validated held out (replayed
causally, app.emg.validation), then trials whose assistance judges the force that model
estimates from the subject's EMG while the trial runs (app.emg.feed), beside the same
trials judged by the force sensor.

Run: .venv/bin/python bench/emg_assistance.py [--subject 1] [--tolerance 20 30]
     [--model network] [--muscles thesis|all] [--trials 3] [--repetitions 5]
Prints, per tolerance: the held-out validation (torque R², force RMSE, the share of
samples whose cone test agrees with the sensor's); and, if the model passes, per
assistance mode: the estimate's force RMSE against the sensor's at each estimate, the
share of exercise ticks the EMG-fed scheme judged as the sensor would have, the in-cone
shares, the robot's and the patient's net work, the tracking RMSE and how much the
robot's torque changed.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from app.emg.feed import SyntheticEmgFeed
from app.emg.modelfile import emg_model, save_approved
from app.emg.subjects import Subject, record_session
from app.emg.validation import check_model
from app.trials.headless import simulate_to_file
from app.trials.reader import read_trial
from core.emg.force import in_cone
from core.emg.synthetic import MUSCLES, THESIS_MUSCLES
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import PERIOD_S

EXERCISE = 2


class LostEmgFeed(SyntheticEmgFeed):
    """The EMG lost from the start: every estimate NaN, so the scheme never gives way (what
    the patient's push is worth to the robot, by its absence)."""

    def __call__(self, records) -> None:
        self._pipeline.set_force_estimate(math.nan, math.nan, int(records[-1]["tick"]))


def closed_loop(folder: Path, model, subject: Subject, assist: str, tolerance: float,
                repetitions: int, drive: bool) -> dict:
    out = {}
    for source in ("sensor", "emg", "lost"):
        params = THESIS_SUBJECT.replace(assist=assist, tolerance_rad=tolerance,
                                        repetitions=repetitions)
        feed = None
        if source != "sensor":
            params = params.replace(force_estimate=model.name,
                                    force_estimate_sha256=model.content_sha256)
            feed = (SyntheticEmgFeed if source == "emg" else LostEmgFeed)(
                subject, model, params.arm(), period_s=PERIOD_S)
        path = folder / f"{assist}_{source}_{math.degrees(tolerance):.0f}.h5"
        started = time.perf_counter()
        options = {"drive_N": subject.drive_N} if drive else None
        _, analysis, _ = simulate_to_file(params, path, patient=subject.patient, feed=feed,
                                          patient_options=options)
        trial = read_trial(path)
        ch = trial.channels
        ex = ch["phase"] == EXERCISE
        m = analysis.metrics
        row = {"s": time.perf_counter() - started,
               "active": float(ch["assistance_active"][ex].mean()),
               "robot_J": m.robot_work_J, "patient_J": m.patient_work_J,
               "share": m.robot_work_share, "rmse_mm": (1e3 * m.rmse_x_m, 1e3 * m.rmse_y_m),
               "torque": ch["torque_commanded"][ex]}
        if source == "emg":
            sensor_judged = in_cone(ch["force"][ex], ch["direction_desired"][ex], tolerance)
            row["alike"] = float(np.mean(sensor_judged == ch["assistance_active"][ex]))
            row["sensor_active"] = float(sensor_judged.mean())
            log = feed.log.arrays()
            inside = ch["phase"][log["tick"]] == EXERCISE
            error = (log["force"] - ch["force"][log["tick"]])[inside]
            row["force_rmse"] = tuple(np.sqrt(np.mean(error * error, axis=0)))
            row["force_rms"] = tuple(np.sqrt(np.mean(ch["force"][log["tick"]][inside] ** 2,
                                                     axis=0)))
        out[source] = row
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--subject", type=int, default=1)
    ap.add_argument("--tolerance", type=float, nargs="+", default=[20.0, 30.0],
                    help="cone half-angles (degrees)")
    ap.add_argument("--model", choices=("linear", "network", "muscle"), default="network")
    ap.add_argument("--muscles", choices=("thesis", "all"), default="thesis")
    ap.add_argument("--trials", type=int, default=3, help="trials recorded (the last held out)")
    ap.add_argument("--repetitions", type=int, default=5)
    ap.add_argument("--patient", default="healthy", help="the subject's virtual patient")
    ap.add_argument("--no-drive", action="store_true",
                    help="the closed-loop trials without the subject's own push along the "
                         "path (the virtual patient's default effort)")
    args = ap.parse_args()
    muscles = THESIS_MUSCLES if args.muscles == "thesis" else MUSCLES
    subject = Subject.drawn(args.subject, muscles=muscles, patient=args.patient)
    print(f"synthetic subject {args.subject} ({args.patient}; {', '.join(muscles)}), "
          f"{args.trials} trials of "
          f"{args.repetitions} × 4 s recorded with no help, the last held out; {args.model}")
    with tempfile.TemporaryDirectory() as tmp:
        for degrees in args.tolerance:
            tolerance = math.radians(degrees)
            folder = Path(tmp) / f"t{degrees:g}"
            folder.mkdir()
            paths = record_session(folder, subject, trials=args.trials,
                                   repetitions=args.repetitions, tolerance_rad=tolerance)
            started = time.perf_counter()
            # the held-out trial replayed with the synthetic stream's own lateness
            checked = check_model(paths, args.model, test=[paths[-1]], as_live=True,
                                  latency_s=SyntheticEmgFeed.latency_of(subject))
            v = checked.validations[0]
            f = v.force
            took = time.perf_counter() - started
            print(f"\n{degrees:g}° cone. Held out (trained in {took:.1f} s): "
                  f"torque R² {v.score.r2[0]:.3f}, {v.score.r2[1]:.3f}; force RMSE "
                  f"{f.rmse_N[0]:.2f}, {f.rmse_N[1]:.2f} N; cone judged as the sensor's "
                  f"{f.cone_agreement:.1%} (in the cone: sensor {f.sensor_in_cone:.1%}, "
                  f"estimate {f.estimate_in_cone:.1%}); {'passes' if v.usable else 'refused'}")
            if not v.usable:
                print(f"  {v.why_not}")
                continue
            models = Path(tmp) / "models"
            save_approved(models, f"s{args.subject}_{degrees:g}", checked)
            model = emg_model(models, f"s{args.subject}_{degrees:g}")
            print("  mode       source  ticks judged alike  in cone (sensor's rule)  "
                  "robot J  patient J  share   RMSE x/y mm  force RMSE / RMS N    s")
            for assist in ("thesis", "as-needed"):
                rows = closed_loop(folder, model, subject, assist, tolerance, args.repetitions,
                                   not args.no_drive)
                change = rows["emg"]["torque"] - rows["sensor"]["torque"]
                lost = rows["lost"]["torque"] - rows["sensor"]["torque"]
                for source, r in rows.items():
                    alike = f"{r['alike']:.1%}" if "alike" in r else "—"
                    cone = (f"{r['active']:.1%} ({r['sensor_active']:.1%})" if "alike" in r
                            else f"{r['active']:.1%}")
                    force = (f"{r['force_rmse'][0]:.2f}, {r['force_rmse'][1]:.2f} / "
                             f"{r['force_rms'][0]:.2f}, {r['force_rms'][1]:.2f}"
                             if "force_rmse" in r else "—")
                    print(f"  {assist:<10} {source:<7} {alike:>18}  {cone:>23}  "
                          f"{r['robot_J']:7.2f}  {r['patient_J']:9.2f}  {r['share']:5.1%}  "
                          f"{r['rmse_mm'][0]:5.1f} / {r['rmse_mm'][1]:4.1f}  {force:>18}  "
                          f"{r['s']:.1f}")
                print(f"  {assist:<10} the robot's torque against the sensor-fed trial's: "
                      f"{np.sqrt(np.mean(change ** 2)):.3f} N·m RMS with the estimate, "
                      f"{np.sqrt(np.mean(lost ** 2)):.3f} with it lost")


if __name__ == "__main__":
    main()
