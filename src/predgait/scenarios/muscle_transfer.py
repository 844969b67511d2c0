"""Muscle transfer surgery on an OpenSim model's paths (e.g. distal rectus femoris transfer).

Rectus femoris transfer (Gage JR et al. 1987, Dev Med Child Neurol 29:159-166; Delp SL,
Ringwelski DA, Carroll NC 1994, J Biomech 27:1201-1211, moment arms after transfer to the
semitendinosus, gracilis, sartorius or iliotibial band): the muscle keeps its proximal
points and loses its points on the donor's insertion body and its conditional and moving
points, which belong to the old route (for rect_fem: the femoral-condyle
ConditionalPathPoint standing in for the wrap over the patella, and the patellar-tendon
MovingPathPoint on the tibia); the donor's points on its insertion body (bifemsh_r or
hamstrings_r: the two posterior tibia points they share in this planar model, whose
hamstrings lump the semitendinosus, the usual transfer site) are appended as fixed points.
The tendon slack length is then set so that the fibre length at the model's default pose is
unchanged (the transfer sutured at its pre-operative tension). Straight-line segments, as
the rest of the model: the transferred path runs behind the knee axis, a knee flexor at
every knee angle, as Delp et al. (1994) computed for posterior transfer sites; Asakawa et
al. (2002, J Biomech 35:1029-1037; 2004, J Bone Joint Surg Am 86:348) measured by MRI that
transferred rectus femoris fibres still shorten with knee extension (scar connections to the
vasti), so the full flexor conversion is the model's best case.

Lengths and moment arms of the transferred path come from the exact geometry
(:class:`predgait.dynamics.muscle_paths.PathGeometry` on the edited model record) and a new
smooth fit (:func:`predgait.dynamics.muscle_paths.smooth_paths`, ~1 s).
"""

from __future__ import annotations

from dataclasses import replace

from predgait.errors import InputError
from predgait.models.osim import PointKind


def transferred_osim(osim, muscle: str, donor: str):
    """An OsimModel whose ``muscle`` ends on ``donor``'s distal points (module docstring).

    Raises:
        InputError: The muscle has no fixed point proximal to the donor's insertion body.
    """
    record, source = osim.muscle(muscle), osim.muscle(donor)
    parent = {j.child.body: j.parent.body for j in osim.joints}

    def depth(body: str) -> int:
        return 0 if body not in parent else 1 + depth(parent[body])

    distal = max(depth(p.body) for p in source.path)
    bodies = tuple(dict.fromkeys(p.body for p in source.path if depth(p.body) == distal))
    kept = tuple(p for p in record.path
                 if depth(p.body) < distal and p.kind is PointKind.FIXED)
    if not kept:
        raise InputError(f"{osim.source}, line {record.line}: muscle {muscle!r} has no point "
                         f"proximal to {donor!r}'s insertion on {', '.join(bodies)}; it "
                         "cannot be transferred there.")
    moved = tuple(replace(p, name=f"{muscle}-transfer-{p.name}") for p in source.path
                  if p.body in bodies)
    muscles = tuple(replace(m, path=kept + moved) if m.name == muscle else m
                    for m in osim.muscles)
    return replace(osim, muscles=muscles)


def transferred_model(built, osim, muscles, names: tuple[str, ...]):
    """The built model with transferred paths, the muscles re-tensioned, and their fit.

    Args:
        built: Baseline :class:`~predgait.models.osim_model.OsimPlanarModel`.
        osim: Its OsimModel after :func:`transferred_osim` (one or more muscles).
        muscles: The MuscleSet so far.
        names: The transferred muscles: their tendon slack lengths change by the change of
            their path length at the model's default pose (same fibre length there).

    Returns:
        (edited OsimPlanarModel, edited MuscleSet, smooth paths on model q).
    """
    from predgait.dynamics.muscle_paths import PathGeometry, smooth_paths

    edited = replace(built, osim=osim)
    before, after = PathGeometry(built), PathGeometry(edited)
    default = [c.default_value for c in osim.coordinates]
    change = after.lengths(default) - before.lengths(default)
    for name in names:
        old = muscles.muscles[muscles.index(name)].tendon_slack_length
        muscles = muscles.edited(name, tendon_slack_length=old
                                 + change[before.muscle_names.index(name)])
    return edited, muscles, smooth_paths(edited, on_model_q=True)
