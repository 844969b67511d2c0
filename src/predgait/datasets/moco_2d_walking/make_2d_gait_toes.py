"""Write ``2D_gait_toes.osim``: Moco's 2D_gait.osim with a passive toe joint per foot.

Run from anywhere: ``python make_2d_gait_toes.py`` (standard library only; a test checks
that the bundled file is what this script writes). Text edits of the original file, so
a diff shows every change:

1. ``mtp_r`` / ``mtp_l``: WeldJoint -> PinJoint about the same frames, coordinate
   ``mtp_angle_r`` / ``_l`` (OpenSim sign: + is toe extension, the toes turning up about
   +Z), range -30..60 deg, default 0.
2. A SpringGeneralizedForce per toe joint, 25 N m/rad and 0.03 N m s/rad about 0 (the
   passive metatarsophalangeal moment of Sasaki & Neptune 2009 as PredSim adds it to its
   models; Falisse, Afschrift & De Groote 2022, PLoS ONE 17:e0256311, whose two-segment
   feet elicit stance knee flexion that single-segment feet do not).
3. Contact: the front sphere (radius 15 mm) moves back under the metatarsal heads, 10 mm
   behind the toe joint on the calcaneus; a toe sphere of the same radius and height sits on
   the toes 40 mm ahead of the joint, with the front contact's force parameters. The heel
   spheres are unchanged.
"""

from __future__ import annotations

import re
from pathlib import Path

HERE = Path(__file__).resolve().parent
SOURCE = HERE / "2D_gait.osim"
TARGET = HERE / "2D_gait_toes.osim"

#: Where the toe joint sits on the calcaneus (2D_gait.osim's mtp offset), m.
MTP_X, MTP_Y = 0.16340967877419901, -0.00182784875586352
FRONT_Y = -0.015653763790965898         # the front sphere's centre height (unchanged), m
BALL_X = MTP_X - 0.010                  # metatarsal-head sphere on the calcaneus, m
TOE_X = 0.040                           # toe sphere ahead of the joint, in the toes frame, m
MTP_RANGE = (-0.5235987755982988, 1.0471975511965976)   # -30..60 deg
SPRING = {"stiffness": 25.0, "viscosity": 0.03}


def _pin(text: str, side: str) -> str:
    start = text.index(f'<WeldJoint name="mtp_{side}">')
    end = text.index("</WeldJoint>", start) + len("</WeldJoint>")
    block = text[start:end].replace("<WeldJoint", "<PinJoint").replace("</WeldJoint>",
                                                                       "</PinJoint>")
    child = f"<socket_child_frame>toes_{side}_offset</socket_child_frame>"
    coordinates = (f"{child}\n\t\t\t\t\t<coordinates>\n"
                   f'\t\t\t\t\t\t<Coordinate name="mtp_angle_{side}">\n'
                   f"\t\t\t\t\t\t\t<range>{MTP_RANGE[0]!r} {MTP_RANGE[1]!r}</range>\n"
                   "\t\t\t\t\t\t</Coordinate>\n\t\t\t\t\t</coordinates>")
    return text[:start] + block.replace(child, coordinates) + text[end:]


def _forces(text: str) -> str:
    front_l = text.index('<SmoothSphereHalfSpaceForce name="contactFront_l">')
    end = text.index("</SmoothSphereHalfSpaceForce>", front_l) + len(
        "</SmoothSphereHalfSpaceForce>")
    added = []
    for side in "rl":
        start = text.index(f'<SmoothSphereHalfSpaceForce name="contactFront_{side}">')
        stop = text.index("</SmoothSphereHalfSpaceForce>", start) + len(
            "</SmoothSphereHalfSpaceForce>")
        added.append(text[start:stop].replace(f"contactFront_{side}", f"contactToe_{side}")
                     .replace(f"/front_{side}<", f"/toe_{side}<"))
    for side in "rl":
        added.append(f'<SpringGeneralizedForce name="mtp_passive_{side}">\n'
                     f"\t\t\t\t<coordinate>mtp_angle_{side}</coordinate>\n"
                     f"\t\t\t\t<stiffness>{SPRING['stiffness']!r}</stiffness>\n"
                     "\t\t\t\t<rest_length>0</rest_length>\n"
                     f"\t\t\t\t<viscosity>{SPRING['viscosity']!r}</viscosity>\n"
                     "\t\t\t</SpringGeneralizedForce>")
    return text[:end] + "".join(f"\n\t\t\t{a}" for a in added) + text[end:]


def _spheres(text: str) -> str:
    for side, z in (("r", 1.0), ("l", -1.0)):
        text, n = re.subn(
            rf'(<ContactSphere name="front_{side}">.*?<location>)[^<]*(</location>)',
            lambda m, z=z: f"{m.group(1)}{BALL_X!r} {FRONT_Y!r} {z * 0.0052179212636552993!r}"
                      f"{m.group(2)}", text, flags=re.S)
        assert n == 1, side
        start = text.index(f'<ContactSphere name="front_{side}">')
        stop = text.index("</ContactSphere>", start) + len("</ContactSphere>")
        toe = (text[start:stop].replace(f'name="front_{side}"', f'name="toe_{side}"')
               .replace(f"/bodyset/calcn_{side}", f"/bodyset/toes_{side}"))
        toe = re.sub(r"<location>[^<]*</location>",
                     f"<location>{TOE_X!r} {FRONT_Y - MTP_Y!r} "
                     f"{z * 0.0052179212636552993!r}</location>", toe)
        text = text[:stop] + "\n\t\t\t\t" + toe + text[stop:]
    return text


def toes_model_text(source: str) -> str:
    """The text of 2D_gait_toes.osim from the text of 2D_gait.osim."""
    text = source.replace('<Model name="2D_gait">', '<Model name="2D_gait_toes">')
    for side in "rl":
        text = _pin(text, side)
    return _spheres(_forces(text))


if __name__ == "__main__":
    TARGET.write_text(toes_model_text(SOURCE.read_text()))
    print(f"wrote {TARGET}")
