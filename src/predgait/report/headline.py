"""The headline of a result folder: what was run, on which trial, status, key numbers.

:func:`headline` reads a folder's ``summary.json`` (or ``solution.json``) and returns a
:class:`Headline`: a title, the trial, the status, 3-6 numbers with units and one
sentence of interpretation written from those numbers (never canned text: each clause
states a value of this result).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path, PurePath

from predgait.report.tidy import format_quantity

GOOD = ("completed", "solved", "ok", "success", "converged")


@dataclass(frozen=True)
class Headline:
    """What a person reads first about one result."""

    title: str
    trial: str
    status: str
    numbers: list[tuple[str, str]] = field(default_factory=list)
    sentence: str = ""
    note: str = ""
    warnings: tuple[str, ...] = ()   # plausibility warnings (analysis.plausibility), one line each

    @property
    def ok(self) -> bool:
        """The run ended as planned (a fall or a warning is a finding, not a failure)."""
        return (self.status in GOOD or self.status in ("event", "fell")
                or self.status in (f"{g} with warnings" for g in GOOD))


def trial_name(provenance: dict) -> str:
    """The trial's file name (never its folder), or the bundled/synthetic label."""
    trial = str(provenance.get("trial", "") or "")
    if not trial:
        return "-"
    name = PurePath(trial).name
    return f"{name} (bundled subject01)" if "datasets" in trial else name


def _t(value) -> str:
    return format_quantity("_s", value)


def _deg(value) -> str:
    return format_quantity("_deg", value)


def _inverse(s: dict) -> Headline:
    peaks = s["peak_moments_n_m_per_kg"]
    ranges = s["angle_range_deg"]
    joints = ("hip_flexion", "knee_flexion", "ankle_dorsiflexion")
    biggest = max(joints, key=lambda j: max(abs(peaks[f"{j}_moment_min"]),
                                            abs(peaks[f"{j}_moment_max"])))
    peak = max(abs(peaks[f"{biggest}_moment_min"]), abs(peaks[f"{biggest}_moment_max"]))
    knee = ranges["knee_flexion"]
    residual = max(s.get("ik_rms_residual_m", {}).values(), default=float("nan"))
    side = s["provenance"].get("side", "")
    numbers = [
        ("peak ankle plantarflexor moment",
         format_quantity("_n_m_per_kg", -peaks["ankle_dorsiflexion_moment_min"])),
        ("peak knee extensor moment",
         format_quantity("_n_m_per_kg", -peaks["knee_flexion_moment_min"])),
        ("peak hip extensor moment", format_quantity("_n_m_per_kg",
                                                     -peaks["hip_flexion_moment_min"])),
        ("knee flexion range", f"{knee[0]:.1f} to {knee[1]:.1f} deg"),
        ("hip flexion range", f"{ranges['hip_flexion'][0]:.1f} to "
                              f"{ranges['hip_flexion'][1]:.1f} deg"),
        ("largest IK joint-centre error (RMS)", f"{1000 * residual:.1f} mm"),
    ]
    sentence = (f"Over the {s.get('window', 'analysed window')} the "
                f"{biggest.split('_')[0]} carries the largest moment "
                f"({peak:.2f} N m/kg) and the knee moves through {knee[1] - knee[0]:.1f} deg"
                f"; the ground reaction is {s.get('ground_reaction', 'measured')}.")
    return Headline(f"Inverse dynamics, {side} leg", trial_name(s["provenance"]),
                    s["status"], numbers, sentence)


def _inverse3d(s: dict) -> Headline:
    ik, force = s.get("ik_rms_m", {}), s.get("pelvis_residual_force_N", {})
    trusted = s.get("ik_trusted_rms_m") or {}
    moment = s.get("pelvis_residual_moment_Nm", {})
    numbers = [("frames", str(s.get("frames"))),
               ("IK marker error, mean of frame RMS", f"{1000 * ik.get('mean', 0):.1f} mm"),
               *([("IK marker error, trusted markers (weight > 0.5)",
                   f"{1000 * trusted['mean']:.1f} mm")] if trusted.get("mean") is not None
                 else []),
               *[(f"IK marker error, {name.replace('_', ' ')} (RMS)", f"{1000 * rms:.1f} mm")
                 for name, rms in s.get("ik_rms_by_region_m", {}).items() if rms is not None],
               ("frames flagged by IK", str(len(s.get("ik_flagged_frames", [])))),
               ("pelvis residual force (RMS)", f"{force.get('rms', float('nan')):.1f} N"),
               ("pelvis residual moment (RMS)", f"{moment.get('rms', float('nan')):.1f} N m")]
    lower = s.get("ik_rms_by_region_m", {}).get("pelvis_and_legs")
    legs = "" if lower is None else f" ({1000 * lower:.1f} mm at the pelvis and legs)"
    if trusted.get("mean") is not None:
        legs += (f" and {1000 * trusted['mean']:.1f} mm over the {len(trusted['markers'])} "
                 "markers the fit trusts")
    sentence = (f"The whole body is fitted to the markers with {1000 * ik.get('mean', 0):.1f} "
                f"mm mean RMS error{legs}; the residual force the pelvis would need to balance the "
                f"measured loads is {force.get('rms', float('nan')):.0f} N RMS.")
    return Headline("Whole-body inverse kinematics and dynamics",
                    trial_name(s.get("provenance", {})), "completed", numbers, sentence)


def _resynthesis(s: dict) -> Headline:
    main, runs = s["runs"][0], s["runs"]
    best = max(runs, key=lambda r: r.get("time_to_fall_s") or r.get("end_time_s") or 0.0)
    numbers = [("time to fall", _t(s.get("time_to_fall_s"))),
               (f"deviation exceeds {s['threshold_deg']:g} deg at",
                _t(s.get("time_to_threshold_s"))),
               *[(f"RMS {k} deviation", _deg(v)) for k, v in s["rms_deg"].items()],
               ("GRF RMS error (vertical)", format_quantity("_n", s["grf_rms_n"]["z"]))]
    start = (s.get("stability") or [{}])[0]
    why = ""
    if start.get("unstable"):
        why = (f" The driven leg has {start['unstable']} unstable mode(s) at the start "
               f"(errors grow e-fold every {1000 * start['e_folding_time_s']:.0f} ms), so "
               "small errors in the measured moments grow without feedback.")
    first = (f"Driven by its own inverse-dynamics moments, the leg leaves the measured "
             f"motion by {s['threshold_deg']:g} deg at {_t(s.get('time_to_threshold_s'))} "
             f"({main.get('coordinate_at_threshold') or 'a joint'} first)")
    fall = s.get("time_to_fall_s")
    first += f" and falls at {_t(fall)}." if fall is not None else " and does not fall."
    if best is not main:
        lasts = best.get("time_to_fall_s") or best.get("end_time_s")
        first += f" With '{best['name']}' it lasts {_t(lasts)}."
    return Headline("Forward re-synthesis of the measured walk",
                    trial_name(s["provenance"]), s["status"], numbers, first + why)


def _collapse(s: dict) -> Headline:
    stab = s.get("stability_at_start", {})
    numbers = [("time to fall", _t(s.get("time_to_fall_s"))),
               ("unstable modes at the start", str(stab.get("unstable", "-"))),
               ("e-folding time", format_quantity("_s", stab.get("e_folding_time_s"))),
               ("right-hand side evaluations", str(s.get("n_rhs_evaluations", "-")))]
    spread = [r["time_to_fall_s"] for r in s["runs"] if r.get("time_to_fall_s") is not None]
    sentence = (f"From standing the passive leg falls at {_t(s.get('time_to_fall_s'))}; its "
                f"{stab.get('unstable', 0)} unstable mode(s) double the error every "
                f"{1000 * 0.693 * (stab.get('e_folding_time_s') or float('nan')):.0f} ms.")
    if len(spread) > 1:
        sentence += (f" The {len(spread)} integrator settings agree within "
                     f"{1000 * (max(spread) - min(spread)):.0f} ms.")
    return Headline("Collapse of the leg from standing", "-", s["status"], numbers, sentence)


def _rod(s: dict) -> Headline:
    rms = {k: v["base_pitch"] * 57.29577951308232 for k, v in s["rms"].items()}
    numbers = [(f"RMS pitch error, {k} forces", f"{v:.4f} deg") for k, v in rms.items()]
    sentence = ""
    if {"inertial", "body"} <= set(rms) and rms["body"] > 0:
        sentence = (f"End forces given in the rod's frame track the synthetic trial "
                    f"{rms['inertial'] / rms['body']:.0f}x better than forces given in the "
                    f"lab frame ({rms['body']:.4f} vs {rms['inertial']:.4f} deg RMS).")
    return Headline("Rod: inertial- vs body-frame forces", trial_name(s["provenance"]),
                    s["status"], numbers, sentence)


def _gait7(s: dict) -> Headline:
    grf = s["grf"]
    numbers = [(f"vertical GRF correlation, {side}", f"{g['correlation']:.2f}")
               for side, g in grf.items()]
    numbers += [(f"vertical GRF RMS error, {side}", f"{g['rms_n']:.0f} N")
                for side, g in grf.items()]
    knee = [r for r in s["runs"] if (r.get("knee_run") or {}).get("time_to_fall_s")]
    numbers.append(("knee-driven runs that fall", f"{len(knee)} of "
                    f"{sum(1 for r in s['runs'] if r.get('knee_run'))}"))
    worst = min(grf.values(), key=lambda g: g["correlation"])
    sentence = (f"On the contact model the measured motion produces vertical ground "
                f"reactions correlated {worst['correlation']:.2f}-"
                f"{max(g['correlation'] for g in grf.values()):.2f} with the plates "
                f"(RMS error up to {max(g['rms_n'] for g in grf.values()):.0f} N); "
                f"{len(knee)} knee-driven variant(s) fall.")
    return Headline("gait7: 7-link model on contacts", trial_name(s["provenance"]),
                    s["status"], numbers, sentence)


def _fullbody(s: dict) -> Headline:
    runs = s["runs"]
    done = [r["name"] for r in runs if r["status"] == "completed"]
    longest = max(runs, key=lambda r: r.get("simulated_s") or 0.0)
    numbers = [("variants", str(len(runs))), ("completed without falling", str(len(done))),
               ("first variant falls at", _t(runs[0].get("time_to_fall_s"))),
               ("longest run", f"{longest['name']}, {_t(longest.get('simulated_s'))}")]
    first = runs[0]
    sentence = (f"Driven by its 3D inverse-dynamics moments ('{first['name']}') the body "
                f"falls at {_t(first.get('time_to_fall_s'))} ({first.get('fall_criterion')})"
                f"; {len(done)} of {len(runs)} variants complete "
                f"{_t(s['time_span_s'][1] - s['time_span_s'][0])}"
                + (f" ({', '.join(done)})." if done else "."))
    return Headline("Whole-body forward simulation", trial_name(s["provenance"]),
                    s["status"], numbers, sentence)


def _solve(s: dict) -> Headline:
    check = s["resimulation_check"]
    before, after = check["baseline_uncorrected"], check["with_fit"]
    threshold = _deg(s["threshold_deg"]) if s.get("threshold_deg") is not None else \
        "the threshold"
    p = s["parameters"]
    if s["kind"] == "knee_fit":
        numbers = [("k", format_quantity("_n_m_per_rad", p["k"])),
                   ("c", format_quantity("_n_m_s_per_rad", p["c"])),
                   ("theta0", _deg(p["theta0"] * 57.29577951308232))]
        what = f"the fitted knee spring (k = {p['k']:.3g} N m/rad)"
        title = "Knee spring/damper fit"
    elif s["kind"] == "torque_correction":
        numbers = [("mean |torque change|", f"{p['mean_abs_change_n_m']:.3f} N m"),
                   ("max |torque change|", f"{p['max_abs_change_n_m']:.3f} N m")]
        what = f"torques changed by at most {p['max_abs_change_n_m']:.2f} N m"
        title = "Corrected torque histories"
    else:
        numbers = [(k, format_quantity("_n_m_per_rad" if k.startswith("kp") else
                                       "_n_m_s_per_rad", v)) for k, v in p.items()]
        what = "the fitted PD feedback"
        title = "Feedback gains"
    numbers += [("optimiser tracking RMS", ", ".join(
        f"{k} {v:.2f} deg" for k, v in s["optimiser_tracking_rms_deg"].items())),
        (f"re-simulation within {threshold} until", f"{_t(after['time_to_threshold_s'])} "
         f"(uncorrected {_t(before['time_to_threshold_s'])})")]
    held = after["time_to_threshold_s"]
    window = s["window_s"][1] - s["window_s"][0]
    sentence = (f"Ipopt {s['ipopt_status'].replace('_', ' ').lower()} in "
                f"{s['iterations']} iterations; re-simulated by Pinocchio with {what}, the "
                f"leg stays within {threshold} of the measured motion ")
    sentence += (f"for the whole {window:.2f} s window." if held is None else
                 f"until {_t(held)} instead of {_t(before['time_to_threshold_s'])}")
    if held is not None and after["status"] in ("event", "fell"):
        sentence += f", and then falls at {_t(after['end_s'])}"
    sentence += "."
    note = f"These are a {s['what']}." if s.get("what") else ""
    return Headline(title, trial_name(s["provenance"]), s["status"], numbers, sentence, note)


def _torque_feedback(s: dict) -> Headline:
    closed, opened = s["with_feedback"], s["without_feedback"]
    threshold = _deg(s["threshold_deg"])
    rms, unc = s["torque_rms_n_m"], s["inverse_dynamics_uncertainty"]
    worst = max(closed["max_deviation_deg"].values())
    numbers = [("max deviation with feedback", _deg(worst)),
               (f"without feedback beyond {threshold} at", _t(opened["time_to_threshold_s"]))]
    numbers += [(f"{j} feedback RMS", f"{rms['feedback'][j]:.3f} N m "
                 f"(ID spread +-{unc['half_range_rms_n_m'][j]:.2f} N m)") for j in rms["feedback"]]
    window = s["window_s"][1] - s["window_s"][0]
    sentence = (f"With {s['feedforward'].replace('_', ' ')} torques plus time-varying LQR "
                f"feedback the re-simulated leg stays within {_deg(worst)} of the measured "
                f"motion over {window:.2f} s; without the feedback it leaves {threshold} at "
                f"{_t(opened['time_to_threshold_s'])}.")
    return Headline("Torques with feedback", trial_name(s["provenance"]), s["status"],
                    numbers, sentence)


def _fullbody_tracking(s: dict) -> Headline:
    dev = s["deviation"]
    grf = max(dev["grf_rms_percent_bw"].values())
    window = s["window_s"][1] - s["window_s"][0]
    numbers = [("pelvis residual", f"{s['pelvis_residual_max_n']:.1e} N "
                f"(data {s['measured_pelvis_residual_rms_n']:.1f} N RMS)"),
               ("joint change", _deg(dev["all_joints_rms_deg"]) + " RMS"),
               ("GRF change", f"{grf:.1f} % BW RMS (worst axis)"),
               ("solve", f"{s['iterations']} iterations, {s['solve_time_s']:.1f} s")]
    sentence = (f"Over {window:.2f} s the body with its pelvis free satisfies its equations "
                f"of motion to {s['pelvis_residual_max_n']:.1e} N after moving its joints "
                f"{_deg(dev['all_joints_rms_deg'])} RMS and its ground reactions at most "
                f"{grf:.1f} % body weight RMS from the plates")
    torque = dev.get("torque")
    if torque:
        rms, peak, step = (torque["worst"][k] for k in
                           ("sagittal_rms_n_m_per_kg", "peak_n_m", "node_change_n_m"))
        numbers += [("torque vs measured (worst sagittal RMS)",
                     f"{rms['value']:.3f} N m/kg ({rms['joint']})"),
                    ("torque vs measured (peak)", f"{peak['value']:.0f} N m ({peak['joint']})"),
                    ("largest node-to-node torque change",
                     f"{step['value']:.0f} N m ({step['joint']})")]
        sentence += (f"; its joint torques differ from the measured ones by at most "
                     f"{rms['value']:.2f} N m/kg RMS on a sagittal joint ({rms['joint']}) "
                     f"and change by at most {step['value']:.0f} N m from node to node")
    feedback = s.get("feedback")
    if feedback:
        closed, opened = feedback["with_feedback"], feedback["without_feedback"]
        numbers.append(("re-simulation with feedback",
                        "completes" if closed["time_to_fall_s"] is None else
                        f"falls at {_t(closed['time_to_fall_s'])}"))
        numbers.append(("without feedback falls at", _t(opened["time_to_fall_s"])))
        sentence += ("; re-simulated on the contact springs with LQR feedback it "
                     + ("walks the whole window" if closed["time_to_fall_s"] is None else
                        f"falls at {_t(closed['time_to_fall_s'])}")
                     + f", without it falls at {_t(opened['time_to_fall_s'])}")
    return Headline("Whole-body tracking", trial_name(s["provenance"]), s["status"],
                    numbers, sentence + ".")


def _predict(s: dict) -> Headline:
    g, check, rs = s["gait"], s["pinocchio_check"], s["resimulation"]
    numbers = [("speed, stride", f"{g['speed_m_s']:.2f} m/s, {_t(g['stride_time_s'])}"),
               ("steps right / left, cadence", f"{g['right']['step_length_m']:.3f} / "
                f"{g['left']['step_length_m']:.3f} m, {g['cadence_steps_min']:.0f} steps/min"),
               ("right stance", f"{100 * g['right']['stance_fraction']:.0f} % of the stride"),
               ("Pinocchio base residual", f"{check['max_base_residual_n']:.1e} N"),
               ("solve", f"{s['iterations']} iterations, {s['solve_time_s']:.1f} s")]
    sentence = (f"Ipopt ({s['ipopt_status']}) found a {s['cycle']} cycle over {s['nodes']} "
                f"nodes at {g['speed_m_s']:.2f} m/s whose dynamics hold at every node to "
                f"{check['max_base_residual_n']:.1e} N")
    if rs is not None:
        numbers.append(("re-simulation with TVLQR", f"{rs['status']}, max "
                        f"{_deg(rs['max_angle_deviation_deg'])} from the prediction"))
        sentence += (f"; the engine re-simulates it with feedback to within "
                     f"{_deg(rs['max_angle_deviation_deg'])}")
    return Headline("Predicted gait (gait7)", trial_name(s["provenance"]), s["status"],
                    numbers, sentence + ".")


def _predict_muscles(s: dict) -> Headline:
    g, ip, chk = s["gait"], s["ipopt"], s["pinocchio_check"]
    vg = g["right"]["vertical_grf"]
    numbers = [("speed, stride", f"{g['speed_m_s']:.2f} m/s, {g['stride_length_m']:.3f} m in "
                f"{_t(g['stride_time_s'])}"),
               ("cadence, right stance", f"{g['cadence_steps_min']:.0f} steps/min, "
                f"{g['right']['stance_percent']:.0f} %"),
               ("vertical GRF peak, trough", f"{vg['peak_bw']:.2f}, {vg['valley_bw']:.2f} BW"),
               ("objective", f"{s['objective']:.4g}"),
               ("Pinocchio residual", f"{chk['max_residual']:.1e} N"),
               ("solve", f"{ip['iterations']} iterations, {ip['solve_time_s']:.1f} s")]
    if s["moco"]["available"]:
        numbers.append(("Moco's objective", f"{s['moco']['objective']:.4g}"))
    failed = len(s["warnings"])
    sentence = (f"Ipopt ({ip['status']}) found a muscle-driven half stride over {s['nodes']} "
                f"intervals at {g['speed_m_s']:.2f} m/s; {failed} of "
                f"{len(s['human_likeness'])} human-likeness checks fail")
    return Headline("Predicted gait (18 muscles, 2D_gait.osim)", s["provenance"]["model"],
                    s["status"], numbers, sentence + ".")


def _parameter_numbers(fitted: dict, suffix: str = "") -> list[tuple[str, str]]:
    """The first four fitted parameters: value, interval or "not identifiable"."""
    numbers = []
    for key, r in list(fitted.items())[:4]:
        value = f"{r['value']:.4g} {r['unit']}"
        if r.get("interval95"):
            value += f" [{r['interval95'][0]:.3g}, {r['interval95'][1]:.3g}]"
        if r["status"] != "identified":
            value += ", " + r["status"].replace("_", " ")
        numbers.append((key + suffix, value))
    return numbers


def _decomposition(s: dict) -> Headline:
    fitted = {k: r for k, r in s["parameters"].items() if r["status"] != "fixed"}
    numbers = _parameter_numbers(fitted)
    numbers += [("gait cycles", str(s["gait_cycles"])),
                ("quiet-phase residual SD", format_quantity("_n_m",
                                                            s["quiet_phase_residual_sd_n_m"]))]
    identified = [k for k, r in fitted.items() if r["status"] == "identified"]
    sentence = (f"Splitting the inverse-dynamics moments of {s['gait_cycles']} gait cycle(s) "
                f"into passive and active parts (active ~ 0 in the quiet phases), "
                f"{len(identified)} of {len(fitted)} fitted parameters are identified"
                + (f" ({', '.join(identified)})." if identified else "."))
    return Headline("Passive moment decomposition", trial_name(s["provenance"]),
                    s["status"], numbers, sentence)


def _swing(s: dict) -> Headline:
    fitted = {k: r for k, r in s["parameters"].items() if r["status"] != "fixed"}
    rms = s["angle_rms_deg"]
    numbers = _parameter_numbers(fitted) + [
        ("gait cycles / quiet-phase windows", f"{s['gait_cycles']} / {s['windows']}"),
        ("angle RMS error, ankle / knee", f"{rms['ankle']:.3f} / {rms['knee']:.3f} deg")]
    numbers += [(f"{joint} vs Riener & Edrich 1999: RMS difference; samples within a "
                 f"factor of {c['factor']:g}",
                 f"{c['rms_difference_n_m']:.2f} N m; {100 * c['within_factor_fraction']:.0f} %")
                for joint, c in s.get("literature_check", {}).items()]
    identified = [k for k, r in fitted.items() if r["status"] == "identified"]
    answers = s.get("answers")
    if answers:   # passive_knee_ankle: angles and quiet moments together, one answer a joint
        sentence = (f"Fitting the swing angles and the quiet-phase moments of "
                    f"{s['gait_cycles']} gait cycle(s) together: "
                    + "; ".join(f"{joint}: {a['text']}" for joint, a in answers.items()))
        title = "Passive knee and ankle (angles and quiet moments)"
    else:
        sentence = (f"Simulating the shank and foot under the measured thigh in the quiet "
                    f"phases of {s['gait_cycles']} gait cycle(s) and fitting the measured "
                    f"angles, {len(identified)} of {len(fitted)} fitted parameters are "
                    "identified" + (f" ({', '.join(identified)})." if identified else "."))
        title = "Passive joints from the swing angles"
    return Headline(title, trial_name(s["provenance"]), s["status"], numbers, sentence)


def _shooting(s: dict) -> Headline:
    fitted = {k: r for k, r in s["parameters"].items() if r["status"] != "fixed"}
    numbers = _parameter_numbers(fitted, " (stabilising)")
    rms = s["interval_end_rms_deg"]
    numbers += [("interval-end RMS, knee (with / without)",
                 f"{rms['with_elements']['knee']:.4f} / "
                 f"{rms['without_elements']['knee']:.4f} deg"),
                ("shooting intervals", f"{s['shooting_intervals']} of "
                 f"{s['interval_s'] * 1e3:.1f} ms")]
    check = s.get("whole_cycle_resimulation")
    if check:
        numbers.append((f"first cycle re-synthesized within {_deg(check['threshold_deg'])} "
                        "until (with / without)",
                        " / ".join(_t(run["time_to_threshold_s"])
                                   if run["time_to_threshold_s"] is not None else "the end"
                                   for run in (check["with_elements"],
                                               check["without_elements"]))))
    zero = [k for k, r in fitted.items() if r.get("note", "").startswith("consistent with 0")]
    sentence = (f"Over {s['shooting_intervals']} shooting intervals re-started from the "
                f"measured state, {len(zero)} of {len(fitted)} stabilising parameters are "
                "consistent with zero; the decomposition of the same moments is shown beside "
                "them.")
    return Headline("Stabilising elements (multiple shooting)", trial_name(s["provenance"]),
                    s["status"], numbers, sentence, f"These are {s['what']}.")


#: How a scenario edit kind reads in a sentence.
EDIT_WORDS = {"passive": "a passive spring-damper", "scale_mass": "a scaled mass",
              "scale_length": "a scaled length", "move_com": "a moved centre of mass",
              "add_mass": "an added mass", "lock_joint": "a locked joint",
              "range_of_motion": "a restricted range of motion"}


def describe_edit(edit: dict) -> str:
    """An edit in words: a passive spring-damper at the knee (k 100, theta0 10.0 deg)."""
    where = edit.get("joint") or edit.get("segment") or ""
    what = EDIT_WORDS.get(edit["kind"], edit["kind"].replace("_", " "))
    values = ", ".join(f"{k.removesuffix('_deg').removesuffix('_kg').removesuffix('_m')} "
                       f"{format_quantity(k, v)}" for k, v in edit.items()
                       if k not in ("kind", "joint", "segment"))
    return f"{what} at the {where} ({values})"


def _scenario(s: dict) -> Headline:
    m = s["metrics"]
    edits = "; ".join(describe_edit(e) for e in s["edits"]) or "no edit"
    numbers = [("knee angle change (RMS / max)", f"{m['knee_rms_change_deg']:.1f} / "
                f"{m['knee_max_change_deg']:.1f} deg"),
               ("ankle angle change (RMS / max)", f"{m['ankle_rms_change_deg']:.1f} / "
                f"{m['ankle_max_change_deg']:.1f} deg"),
               ("extra knee feedback torque (RMS)",
                format_quantity("_n_m", m["knee_extra_feedback_rms_n_m"])),
               ("extra ankle feedback torque (RMS)",
                format_quantity("_n_m", m["ankle_extra_feedback_rms_n_m"])),
               ("time to fall", _t(m.get("time_to_fall_s")))]
    if "peak_vertical_grf_n" in m:
        numbers.append(("peak vertical GRF (edited / baseline)",
                        f"{m['peak_vertical_grf_n']:.0f} / "
                        f"{m['baseline_peak_vertical_grf_n']:.0f} N"))
    larger = "ankle" if m["ankle_rms_change_deg"] > m["knee_rms_change_deg"] else "knee"
    sentence = (f"With {edits}, the same drive and control move the {larger} most "
                f"({m[f'{larger}_rms_change_deg']:.1f} deg RMS from the baseline); the "
                f"controller adds {m['knee_extra_feedback_rms_n_m']:.1f} N m RMS at the knee "
                f"and {m['ankle_extra_feedback_rms_n_m']:.1f} N m at the ankle"
                + (f", and the leg falls at {_t(m['time_to_fall_s'])}."
                   if m.get("time_to_fall_s") is not None else "."))
    trial = "subject01 (bundled)" if s.get("trial") == "bundled:subject01" else "-"
    return Headline(f"What-if scenario: {s['scenario']}", trial,
                    s["status"], numbers, sentence)


def _sweep(s: dict) -> Headline:
    numbers = [("runs", str(s["runs"])), ("failed", str(s["failed"])),
               ("wall time", format_quantity("_s", s["wall_time_s"])),
               ("scenarios per second", f"{s['scenarios_per_second']:.2f}")]
    sentence = (f"{s['runs'] - s['failed']} of {s['runs']} scenario variants ran; the plots "
                "below show each outcome over the swept values, the scenario file's own "
                "setting marked.")
    return Headline("Scenario sweep", PurePath(str(s.get("scenario", ""))).name,
                    s["status"], numbers, sentence)


def _kind(s: dict) -> str | None:
    if "peak_moments_n_m_per_kg" in s:
        return "inverse"
    if "pelvis_residual_force_N" in s:
        return "inverse3d"
    if "resimulation_check" in s:
        return "solve"
    if "metrics" in s and "edits" in s:
        return "scenario"
    if "scenarios_per_second" in s:
        return "sweep"
    return s.get("kind")


BUILDERS = {"inverse": _inverse, "inverse3d": _inverse3d, "resynthesis": _resynthesis,
            "collapse": _collapse, "rod": _rod, "gait7": _gait7, "fullbody": _fullbody,
            "solve": _solve, "scenario": _scenario, "sweep": _sweep,
            "passive_decomposition": _decomposition, "torque_feedback": _torque_feedback,
            "passive_shooting": _shooting, "passive_swing": _swing, "passive_knee_ankle": _swing,
            "fullbody_tracking": _fullbody_tracking,
            "predict_gait7": _predict, "predict_muscles_2d": _predict_muscles}


def summary_file(folder: Path) -> Path | None:
    """The folder's ``summary.json`` or ``solution.json``, if any."""
    for name in ("summary.json", "solution.json"):
        if (folder / name).is_file():
            return folder / name
    return None


def headline(folder: Path) -> Headline | None:
    """The headline of a result folder, or None when it holds no known summary."""
    path = summary_file(folder)
    if path is None:
        return None
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError):
        return Headline(folder.name, "-", "unreadable summary")
    unknown = Headline(folder.name.replace("_", " "), "-", str(data.get("status", "-")),
                       note=f"No headline: {path.name} is not in a layout this predgait "
                            "version knows; every value is in the details below.")
    builder = BUILDERS.get(_kind(data) or "")
    if builder is None:
        return unknown
    try:
        head = builder(data)
    except (KeyError, TypeError, IndexError, ValueError, ZeroDivisionError):
        return unknown  # e.g. a summary written by another predgait version
    lines = tuple(w for w in data.get("warnings") or () if isinstance(w, str))
    return replace(head, warnings=lines) if lines else head
