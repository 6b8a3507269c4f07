"""The post-processor plug-in protocol, its options and the registry.

A post-processor (a *dialect*) turns a dialect-neutral ``PostedProgram`` (joint or
TCP blocks with feeds, made by ``postproc.posting``) into program text. Built-in
dialects register with ``@register_post``; third-party packages register through
the entry-point group ``impeller_cam.postprocessors`` whose objects are a
post-processor class or instance::

    [project.entry-points."impeller_cam.postprocessors"]
    heidenhain = "my_package.posts:HeidenhainPost"

Loading is lazy: listing the posts never imports a plug-in's optional
dependencies. A plug-in that cannot be imported stays listed (its description
says so) and ``get_post`` re-raises the original ``ImportError`` when it is used.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib import metadata
from math import radians
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from impeller_cam.errors import InputError
from impeller_cam.tolerances import DEFAULT_TOLERANCES

if TYPE_CHECKING:
    from postproc.posting import PostedProgram

#: Entry-point group of third-party post-processors.
ENTRY_POINT_GROUP = "impeller_cam.postprocessors"


@dataclass(frozen=True)
class PostOptions:
    """What the user chose for one posting run (internal units: mm, rad).

    Attributes
    ----------
    tcp : bool
        Program the tool tip in the workpiece frame under tool-centre-point control
        (LinuxCNC ``M428``, Fanuc ``G43.4``) instead of machine joints.
    chordal_tolerance : float
        Largest distance of the tool tip from the straight CL segment between two
        APT records, mm.
    angular_tolerance : float
        Largest angle between the tool axis and the great-circle interpolation of
        the two records' axes, rad.
    block_numbers : bool
        Write ``N`` words.
    block_increment : int
        Step of the ``N`` numbers.
    program_number : int or None
        ``O`` number for dialects that use one (1..9999).
    header, footer : tuple of str
        Lines copied (sanitised) into comments at the top / bottom of the program.
    tool_change : bool
        Write ``T<n> M6`` and tool-length compensation at each tool change.
    spindle : bool
        Write ``S`` and ``M3``/``M4``/``M5``.
    coolant : bool
        Write ``M8``/``M9`` as the operations request.
    safe_retract : bool
        Retract to ``retract_z`` and re-orient before every rapid move that turns a
        rotary axis (between operations and between 3+2 segments).
    retract_z : float or None
        Machine Z of the tool tip for safe retracts, mm; default: the Z axis's
        upper limit minus the tool's gauge length.
    tool_lengths : Mapping[int, float]
        Gauge length (spindle nose to tip, the controller's tool-length offset) per
        tool number, mm. Used for the Z travel check (joint Z = program Z + length)
        and the default retract height; tools not listed count as 0 (the tip itself
        is checked against the Z limits).
    decimals : int
        Digits after the point for X, Y, Z (mm) and A, C (deg).
    feed_decimals : int
        Digits after the point for F.
    blend_tolerance : float or None
        Path-blending tolerance written where the dialect supports it (LinuxCNC
        ``G64 P``), mm; None: the chordal tolerance.
    dialect_options : Mapping[str, str]
        The dialect's own options (``impeller-cam posts`` lists them), already
        resolved by ``postproc.posts.choices.resolve_dialect_options``; a dialect
        takes its declared default for a key that is missing.
    """

    tcp: bool = False
    chordal_tolerance: float = DEFAULT_TOLERANCES.chordal
    angular_tolerance: float = DEFAULT_TOLERANCES.angular
    block_numbers: bool = False
    block_increment: int = 10
    program_number: int | None = None
    header: tuple[str, ...] = ()
    footer: tuple[str, ...] = ()
    tool_change: bool = True
    spindle: bool = True
    coolant: bool = True
    safe_retract: bool = True
    retract_z: float | None = None
    tool_lengths: Mapping[int, float] = field(default_factory=dict)
    decimals: int = 4
    feed_decimals: int = 3
    blend_tolerance: float | None = None
    dialect_options: Mapping[str, str] = field(default_factory=dict)

    def option(self, name: str, default: str) -> str:
        """The dialect option ``name`` (``default`` when not given).

        Parameters
        ----------
        name : str
            Option name (``[control.options]`` key or ``--post-option KEY``).
        default : str
            Value when the option is not given.

        Returns
        -------
        str
        """
        return str(self.dialect_options.get(name, default))

    def __post_init__(self) -> None:
        def bad(name: str, value: Any, accepted: str) -> InputError:
            return InputError(f"invalid post option {name}", field=name, value=value,
                              accepted=accepted)

        if not (self.chordal_tolerance > 0 and self.chordal_tolerance < 10):
            raise bad("--tolerance", self.chordal_tolerance, "a length in mm, 0 < t < 10")
        if not (self.angular_tolerance > 0 and self.angular_tolerance <= radians(45)):
            raise bad("--angular-tolerance", self.angular_tolerance,
                      "an angle 0 < a <= 45 deg (given in radians here)")
        if self.program_number is not None and not 1 <= self.program_number <= 9999:
            raise bad("--program-number", self.program_number, "an integer 1..9999")
        if not 1 <= self.block_increment <= 1000:
            raise bad("block_increment", self.block_increment, "an integer 1..1000")
        if not 1 <= self.decimals <= 6:
            raise bad("decimals", self.decimals, "an integer 1..6")
        if not 0 <= self.feed_decimals <= 6:
            raise bad("feed_decimals", self.feed_decimals, "an integer 0..6")
        if self.blend_tolerance is not None and not self.blend_tolerance >= 0:
            raise bad("blend_tolerance", self.blend_tolerance, "a length >= 0 mm")
        if self.retract_z is not None and not abs(self.retract_z) < 1e6:
            raise bad("retract_z", self.retract_z, "a finite machine Z in mm")
        for tool, length in self.tool_lengths.items():
            if not (isinstance(tool, int) and 0.0 <= length < 1e4):
                raise bad("tool_lengths", {tool: length}, "tool number -> length 0..1e4 mm")


@runtime_checkable
class PostProcessor(Protocol):
    """What a dialect plug-in provides.

    Attributes
    ----------
    name : str
        Registry key (``--post NAME``).
    description : str
        One line for ``impeller-cam posts``.
    extension : str
        Usual file extension without the dot (``ngc``, ``nc``).
    supports_tcp : bool
        Whether the dialect can write tool-centre-point programs.
    """

    name: str
    description: str
    extension: str
    supports_tcp: bool

    def write(self, program: PostedProgram, options: PostOptions) -> str:
        """The complete program text for ``program`` (ends with a newline).

        Parameters
        ----------
        program : PostedProgram
            The posted program (joints mm, rad).
        options : PostOptions
            The posting options.

        Returns
        -------
        str
        """
        ...


@dataclass
class _Entry:
    name: str
    description: str
    source: str
    load: Callable[[], PostProcessor]
    instance: PostProcessor | None = field(default=None, repr=False)
    error: BaseException | None = field(default=None, repr=False)


_REGISTRY: dict[str, _Entry] = {}
_ENTRY_POINTS_SCANNED = False


def _instantiate(obj: Any) -> PostProcessor:
    post = obj() if isinstance(obj, type) else obj
    if not isinstance(post, PostProcessor):
        raise TypeError(f"{obj!r} is not a post-processor (needs name, description, "
                        "extension, supports_tcp and write())")
    return post


def register_post(cls: type[Any]) -> type[Any]:
    """Class decorator: register a built-in (or in-process) dialect under ``cls.name``.

    Parameters
    ----------
    cls : type
        The dialect class (``name``, ``description``, ``extension``, ``supports_tcp``,
        ``write``).

    Returns
    -------
    type
        ``cls`` unchanged.
    """
    name = str(cls.name)
    _REGISTRY[name] = _Entry(name, str(cls.description), "built-in",
                             lambda: _instantiate(cls))
    return cls


def register_unavailable(name: str, description: str, error: BaseException,
                         source: str = "built-in") -> None:
    """Register a dialect whose import failed; ``get_post(name)`` re-raises ``error``.

    Parameters
    ----------
    name : str
        Dialect name.
    description : str
        What it is (listed with the error by ``impeller-cam posts``).
    error : BaseException
        The import error.
    source : str
        Where the dialect comes from (``built-in`` or an entry point).
    """

    def load() -> PostProcessor:
        raise error

    _REGISTRY[name] = _Entry(name, f"{description} (unavailable: {error})", source, load)


def _scan_entry_points() -> None:
    global _ENTRY_POINTS_SCANNED
    if _ENTRY_POINTS_SCANNED:
        return
    _ENTRY_POINTS_SCANNED = True
    for point in sorted(metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda p: p.name):
        if point.name in _REGISTRY:
            continue  # built-ins win; a plug-in cannot silently replace them
        source = f"entry point {point.value}" + (f" ({point.dist.name})" if point.dist else "")

        def load(point: metadata.EntryPoint = point) -> PostProcessor:
            return _instantiate(point.load())

        entry = _Entry(point.name, "", source, load)
        try:
            entry.instance = load()
            entry.description = entry.instance.description
        except ImportError as error:  # optional dependency missing: listed, fails on use
            entry.error = error
            entry.description = f"(unavailable: {error})"
        _REGISTRY[point.name] = entry


def available_posts() -> list[tuple[str, str, str]]:
    """All registered dialects, sorted by name.

    Returns
    -------
    list of (str, str, str)
        ``(name, description, source)`` of each dialect.
    """
    _load_builtins()
    _scan_entry_points()
    return [(e.name, e.description, e.source) for _, e in sorted(_REGISTRY.items())]


def get_post(name: str) -> PostProcessor:
    """The dialect registered as ``name``.

    Parameters
    ----------
    name : str
        Dialect name (``impeller-cam posts``).

    Returns
    -------
    PostProcessor

    Raises
    ------
    InputError
        No dialect of that name.
    ImportError
        The plug-in is registered but its (optional) dependency is missing: the
        original error of the import.
    """
    _load_builtins()
    _scan_entry_points()
    entry = _REGISTRY.get(name)
    if entry is None:
        raise InputError("unknown post-processor", field="--post", value=name,
                         accepted=", ".join(sorted(_REGISTRY)))
    if entry.error is not None:
        raise entry.error
    if entry.instance is None:
        entry.instance = entry.load()
    return entry.instance


def _load_builtins() -> None:
    import postproc.posts  # noqa: F401  (importing the package registers the built-ins)
