"""XML of an ``.osim`` file with the line of every element, and the one error format.

expat (the C parser behind :mod:`xml.etree`) reports ``CurrentLineNumber`` as each
element opens; :class:`Node` keeps it, so every message of the reader names the file,
the line, the element type and its name: ``2D_gait.osim:123: DeGrooteFregly2016Muscle
'soleus_r': optimal_fiber_length = 0 m; give a positive length.``
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

from predgait.errors import InputError

#: Display-only children, skipped wherever they appear.
VISUAL = frozenset({"FrameGeometry", "attached_geometry", "Appearance", "VisibleObject",
                    "ModelVisualPreferences", "force_visualization_radius",
                    "force_visualization_scale_factor", "display_hints", "default_color"})


@dataclass
class Node:
    """One XML element: tag, attributes, text, children and its 1-based line."""

    tag: str
    attrib: dict[str, str]
    line: int
    children: list[Node] = field(default_factory=list)
    text: str = ""

    @property
    def name(self) -> str:
        """The ``name`` attribute ('' if none)."""
        return self.attrib.get("name", "")

    def find(self, tag: str) -> Node | None:
        """First child with ``tag``."""
        return next((c for c in self.children if c.tag == tag), None)

    def only_child(self, tag: str, f: OsimFile) -> Node:
        """The child ``tag``, which must be there."""
        node = self.find(tag)
        if node is None:
            f.fail(self, f"has no <{tag}>", f"add the <{tag}> element")
        return node


@dataclass
class OsimFile:
    """A parsed file: its root node and the path for messages."""

    path: Path
    root: Node

    @classmethod
    def parse(cls, path: str | Path) -> OsimFile:
        """Parse ``path``; InputError if missing or not well-formed XML."""
        path = Path(path)
        if not path.is_file():
            raise InputError(f"{path}: OpenSim model file not found; give the path of an "
                             ".osim file.")
        data = path.read_bytes()
        try:
            from predgait.textfile import note_input

            note_input(path)
        except ImportError:  # pragma: no cover
            pass
        parser = expat.ParserCreate()
        stack: list[Node] = []
        top: list[Node] = []

        def start(tag, attrib):
            node = Node(tag, dict(attrib), parser.CurrentLineNumber)
            (stack[-1].children if stack else top).append(node)
            stack.append(node)

        def end(tag):
            stack.pop()

        def text(data):
            if stack:
                stack[-1].text += data

        parser.StartElementHandler = start
        parser.EndElementHandler = end
        parser.CharacterDataHandler = text
        try:
            parser.Parse(data, True)
        except expat.ExpatError as exc:
            raise InputError(f"{path}:{exc.lineno}: not well-formed XML "
                             f"({expat.ErrorString(exc.code)}); fix the file.") from None
        if not top or top[0].tag != "OpenSimDocument":
            raise InputError(f"{path}: not an OpenSim model (no <OpenSimDocument>); give "
                             "an .osim file.")
        return cls(path, top[0])

    # -- messages --------------------------------------------------------------
    def fail(self, node: Node, problem: str, fix: str, *, owner: Node | None = None):
        """Raise the one InputError, as ``file:line: Element 'name': problem; fix``."""
        who = node if node.name or owner is None else owner
        label = f"{who.tag} '{who.name}'" if who.name else f"<{who.tag}>"
        if who is not node:
            label += f" <{node.tag}>"
        raise InputError(f"{self.path}:{node.line}: {label}: {problem}; {fix}.")

    def unsupported(self, node: Node, owner: Node | None = None):
        """Refuse an element the reader does not know."""
        where = f" in {owner.tag} '{owner.name}'" if owner is not None else ""
        name = f" '{node.name}'" if node.name else ""
        raise InputError(f"{self.path}:{node.line}: unsupported element <{node.tag}>{name}"
                         f"{where}; predgait reads bodies, Planar/Pin/Weld joints, "
                         "DeGrooteFregly2016Muscle, CoordinateActuator, "
                         "SpringGeneralizedForce and smooth sphere "
                         "contacts only: remove it or replace it by one of these.")

    def check_known(self, node: Node, known: Iterable[str]) -> None:
        """Refuse any child of ``node`` not in ``known`` (display elements pass)."""
        known = set(known)
        for child in node.children:
            if child.tag not in known and child.tag not in VISUAL:
                self.unsupported(child, node)

    def check_unique(self, nodes: list[Node], what: str) -> None:
        """Refuse two elements with the same name."""
        seen: dict[str, Node] = {}
        for node in nodes:
            if node.name in seen:
                self.fail(node, f"a second {what} named '{node.name}' (first on line "
                          f"{seen[node.name].line})", "give each a unique name")
            seen[node.name] = node

    def set_objects(self, node: Node) -> list[Node]:
        """The ``<objects>`` of an OpenSim Set (``<groups>`` must be empty)."""
        self.check_known(node, {"objects", "groups"})
        groups = node.find("groups")
        if groups is not None and groups.children:
            self.unsupported(groups.children[0], node)
        objects = node.find("objects")
        return list(objects.children) if objects is not None else []

    # -- values ----------------------------------------------------------------
    def floats(self, node: Node, owner: Node | None = None) -> tuple[float, ...]:
        """The numbers in a node's text."""
        try:
            return tuple(float(t) for t in node.text.split())
        except ValueError:
            self.fail(node, f"'{node.text.strip()}' is not a list of numbers",
                      "give numbers", owner=owner)

    def vec(self, node: Node, n: int, owner: Node | None = None) -> tuple[float, ...]:
        """Exactly ``n`` finite numbers."""
        values = self.floats(node, owner)
        if len(values) != n or not all(math.isfinite(v) for v in values):
            self.fail(node, f"'{node.text.strip()}' is not {n} finite numbers",
                      f"give {n} numbers", owner=owner)
        return values

    def number(self, node: Node, owner: Node | None = None) -> float:
        """One number (may be inf, as OpenSim's control bounds)."""
        values = self.floats(node, owner)
        if len(values) != 1 or math.isnan(values[0]):
            self.fail(node, f"'{node.text.strip()}' is not one number", "give one number",
                      owner=owner)
        return values[0]

    def boolean(self, node: Node, owner: Node | None = None) -> bool:
        """``true`` or ``false``."""
        text = node.text.strip().lower()
        if text not in ("true", "false"):
            self.fail(node, f"'{node.text.strip()}' is not true or false",
                      "write true or false", owner=owner)
        return text == "true"


def properties(f: OsimFile, node: Node, kinds: dict[str, str], *,
               elements: Iterable[str] = (), ignored: Iterable[str] = ()) -> dict:
    """Read a node's simple properties.

    Args:
        f: The file (for messages).
        node: The element.
        kinds: property tag -> ``float``, ``vec3``, ``vec6``, ``pair``, ``bool``, ``text``.
        elements: Other child tags the caller reads itself.
        ignored: Child tags OpenSim would ignore too (legacy names).

    Returns:
        tag -> value for the properties present.
    """
    f.check_known(node, set(kinds) | set(elements) | set(ignored))
    readers = {"float": f.number, "bool": f.boolean,
               "vec3": lambda n, owner: f.vec(n, 3, owner),
               "vec6": lambda n, owner: f.vec(n, 6, owner),
               "pair": lambda n, owner: f.vec(n, 2, owner),
               "text": lambda n, owner: n.text.strip()}
    out = {}
    for child in node.children:
        kind = kinds.get(child.tag)
        if kind is not None:
            out[child.tag] = readers[kind](child, owner=node)
    return out
