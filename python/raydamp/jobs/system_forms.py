"""The three kinds of user-defined system as JSON: expressions (raydamp.System), a lattice
(raydamp.Chain) and a linear structure (raydamp.LinearStructure), each the to_dict() form of its
class. Each form builds its model (``build``): the one place a kind's JSON meets its class, with
errors naming the path inside "system"."""

from __future__ import annotations

import functools
import json
from collections.abc import Callable, Iterator
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Discriminator, Field, Tag

from ..systems.system.spec import OUTSIDE_CLASS
from .errors import JobError, path_error
from .forms import (
    FILE_ID,
    MAX_CHAIN_SITES,
    MAX_VECTOR,
    Expression,
    FiniteFloat,
    Input,
    MatrixFile,
    Name,
    at_most,
    bounded,
    indices,
    numbers,
)

__all__ = ["SystemInput", "ChainInput", "LinearStructureInput", "StructureInput", "PlanetsInput", "CooForm",
           "DiagonalForm", "FileForm",
           "AnySystemInput", "FileResolver", "MAX_COO_ENTRIES", "MAX_STRUCTURE_DIM", "SYSTEM_TAGS", "MATRIX_TAGS",
           "FORM_TAGS", "VALUE_TAGS"]

def _constant_mass(value: Any) -> Any:
    """An expression where a mass is expected gets the library's explanation as one error, rather than
    one "Input should be a valid number" per form of mass."""
    items = value if isinstance(value, list) else [value]
    if any(isinstance(x, list) and len(x) > _MAX_COORDINATES for x in items):
        return value  # a row too long: its length's error, before any item is looked at
    if any(isinstance(x, str) or (isinstance(x, list) and any(isinstance(y, str) for y in x)) for x in items):
        raise ValueError(f"must be constant: {OUTSIDE_CLASS}")
    return value


# Bounds of an expression system: raydamp.system.spec's own limits, stated in the schema.
_MAX_COORDINATES = 256
_MAX_DENSE = 32
FileResolver = Callable[[str], Any]


class ScalarDamping(Input):
    scalar: FiniteFloat = Field(ge=0, description="D = c M: every momentum decays at rate eps c")


class DiagonalDamping(Input):
    diagonal: bounded(FiniteFloat, _MAX_DENSE, min_length=1) = Field(description="a constant diagonal D")


class MatrixDamping(Input):
    matrix: bounded(bounded(FiniteFloat, _MAX_DENSE), _MAX_DENSE, min_length=1) = Field(
        description="a constant symmetric positive semi-definite D (rows)")


class Damper(Input):
    on: Expression = Field(description="g(q): the dashpot resists its rate of change")
    c: FiniteFloat = Field(1.0, ge=0, description="the dashpot's coefficient")


class DamperDamping(Input):
    dampers: bounded(Damper, 32, min_length=1) = Field(description="D(q) = sum_i c_i grad g_i grad g_i^T")


def _damping_form(value: object) -> str | None:
    if isinstance(value, dict):
        return next((f"{key} form" for key in ("scalar", "diagonal", "matrix", "dampers") if key in value), None)
    forms = ((ScalarDamping, "scalar form"), (DiagonalDamping, "diagonal form"), (MatrixDamping, "matrix form"),
             (DamperDamping, "dampers form"))
    return next((tag for form, tag in forms if isinstance(value, form)), None)


DampingInput = Annotated[Annotated[ScalarDamping, Tag("scalar form")] | Annotated[DiagonalDamping, Tag("diagonal form")]
                         | Annotated[MatrixDamping, Tag("matrix form")] | Annotated[DamperDamping, Tag("dampers form")],
                         Discriminator(_damping_form, custom_error_type="damping_form",
                                       custom_error_message='damping is null, {"scalar": c}, {"diagonal": [...]}, '
                                                            '{"matrix": [[...]]} or {"dampers": [...]}')]
Coordinates = Annotated[Annotated[bounded(Name, _MAX_COORDINATES, min_length=1), Tag("names form")]
                        | Annotated[int, Field(ge=1, le=_MAX_COORDINATES), Tag("count form")],
                        Discriminator(lambda value: "count form" if isinstance(value, int) else "names form")]
# A value that is a number or something else (an expression, a vector), told apart by its type, so that an
# error is about the form the client meant.
NumberOrExpression = Annotated[Annotated[FiniteFloat, Tag("number form")]
                               | Annotated[Expression, Tag("expression form")],
                               Discriminator(lambda value: "expression form" if isinstance(value, str)
                                             else "number form")]


def _number_or_list(value: object) -> str:
    return "vector form" if isinstance(value, list) else "number form"


def _mass_form(value: object) -> str:
    if not isinstance(value, list):
        return "number form"
    return "matrix form" if value and isinstance(value[0], list) else "vector form"


# A number m (M = m I), a diagonal or a matrix, told apart by their shape: an error is about the form meant.
MassInput = Annotated[Annotated[FiniteFloat, Tag("number form")]
                      | Annotated[bounded(FiniteFloat, _MAX_COORDINATES), Tag("vector form")]
                      | Annotated[bounded(bounded(FiniteFloat, _MAX_COORDINATES), _MAX_COORDINATES),
                                  Tag("matrix form")],
                      Discriminator(_mass_form)]


class SystemKind(Input):
    """What every system kind answers for a job (JobSpec walks no JSON): the files it reads, the sizes it
    carries inline and whether it compiles. A kind that reads, carries or compiles nothing keeps these."""

    def files(self, at: tuple) -> Iterator[tuple[tuple, str, str]]:
        return iter(())

    def sizes(self, at: tuple) -> Iterator[tuple[tuple, str, int]]:
        return iter(())

    def compiles(self) -> bool:
        return False

    def compiled_form(self) -> tuple[str, bytes] | None:
        return None


class SystemInput(SystemKind):
    """A user-defined system: raydamp.System.to_dict()'s form. H = 1/2 p^T M^{-1} p + V(q) with
    damping -eps D(q) M^{-1} p; M constant SPD, D(q) symmetric PSD."""

    coordinates: Coordinates = Field(
        description="coordinate names, or their number n (names q0..q{n-1})")
    potential: Expression = Field(description="V(q): numbers, names, + - * / ^, parentheses, pi, and "
                                              "sin cos tan asin acos atan atan2 sinh cosh tanh asinh acosh "
                                              "atanh exp log sqrt cbrt")
    parameters: dict[Name, FiniteFloat] = Field(default_factory=dict, max_length=256)
    mass: Annotated[MassInput, BeforeValidator(_constant_mass), at_most(_MAX_COORDINATES)] = Field(
        1.0, description="a number m (M = m I), a diagonal (n numbers) or an n x n SPD matrix")
    damping: DampingInput | None = Field(
        None, description="null (undamped) or exactly one form")
    eps: FiniteFloat = Field(0.0, ge=0, description="damping strength")
    momenta: dict[Name, Expression] = Field(default_factory=dict, max_length=16,
                                            description="quantities tracked at every step; momenta are p_<coordinate>")
    name: str | None = Field(None, max_length=200)
    constraints: bounded(Expression, 128) = Field(
        default_factory=list,
        description="holonomic constraints g_i(q), each held at 0 (rods, rigid links), run by RATTLE; fewer than n")
    constraint_tol: FiniteFloat = Field(
        1e-12, gt=0, lt=0.01, description="the constraint solve's tolerance, relative to each constraint's scale")
    project_initial: bool = Field(
        False, description="project q0 onto the constraints and p0 onto their tangent space (else refuse them)")

    def files(self, at: tuple) -> Iterator[tuple[tuple, str, str]]:
        return iter(())

    def sizes(self, at: tuple) -> Iterator[tuple[tuple, str, int]]:
        return iter(())  # bounded by the schema (at most 256 coordinates)

    def compiles(self) -> bool:
        return True

    def compiled_form(self) -> tuple[str, bytes] | None:
        return self.build().compiled_form()

    def names(self, dim: int, momenta: int, save_dofs: list[int] | None) -> tuple[list[str], list[str]]:
        """(names of the saved coordinates, momentum map names), as the built System has them."""
        coordinates = self.coordinates
        names = [f"q{i}" for i in range(coordinates)] if isinstance(coordinates, int) else list(coordinates)
        return [names[i] for i in save_dofs] if save_dofs is not None else names, list(self.momenta)

    def build(self, files: FileResolver | None = None):
        from ..systems.system import SpecError

        try:
            return _compiled_system(json.dumps(self.model_dump(exclude_unset=True), sort_keys=True))
        except SpecError as error:
            raise JobError(("system", *error.path), f"system.{error}") from None


@functools.lru_cache(maxsize=32)
def _compiled_system(text: str):
    # Keyed by the canonical JSON: a system checked at submission is not compiled again by the
    # worker, and a sweep over initial states compiles its system once.
    from ..systems.system import System

    return System.from_dict(json.loads(text))


class ChainDampers(Input):
    bonds: bounded(Annotated[int, Field(ge=0)], MAX_VECTOR, items=indices(MAX_VECTOR)) = Field(
        default_factory=list, description="damped bonds (bond b joins sites b-1 and b)")
    sites: bounded(Annotated[int, Field(ge=0)], MAX_VECTOR, items=indices(MAX_VECTOR)) = Field(
        default_factory=list, description="sites with on-site friction")
    # Optional for a chain without dampers ({} is Chain.to_dict()'s form of an undamped chain); required, by
    # raydamp.Chain, once there are bonds or sites.
    c: Annotated[Annotated[FiniteFloat, Tag("number form")]
                 | Annotated[bounded(FiniteFloat, 2 * MAX_VECTOR, items=numbers(2 * MAX_VECTOR)), Tag("vector form")],
                 Discriminator(_number_or_list)] | None = Field(
        None, description="the dashpot coefficient, or one per damper (bonds, then sites)")


class ChainOnSiteInput(Input):
    """An on-site potential U(q_i) on every site: harmonic (k), phi4 (k2, k4) or sine (g); the
    parameters not given take raydamp's defaults (raydamp.chain documents them)."""

    kind: Literal["harmonic", "phi4", "sine"]
    k: FiniteFloat | None = Field(None, ge=0, description="harmonic: U = k q^2/2")
    k2: FiniteFloat | None = Field(None, description="phi4: U = k2 q^2/2 + k4 q^4/4 (k2 < 0: a double well)")
    k4: FiniteFloat | None = Field(None, ge=0)
    g: FiniteFloat | None = Field(None, ge=0, description="sine: U = g (1 - cos q)")


class ChainInput(SystemKind):
    """A lattice: raydamp.Chain.to_dict()'s form. n sites of mass m, neighbours joined by bonds of one
    family, dashpots on chosen bonds or friction on chosen sites (raydamp.chain documents it)."""

    kind: Literal["chain"]
    n: int = Field(ge=2, le=MAX_CHAIN_SITES, description="number of sites")
    bond: Literal["harmonic", "fput", "toda", "morse", "lennard_jones", "expression"] = "fput"
    parameters: dict[Name, NumberOrExpression] = Field(
        default_factory=dict, max_length=64,
        description="the family's parameters (fput: k, alpha, beta; ...); an expression bond gives "
                    "potential: V(r) as text, and its named parameters")
    mass: FiniteFloat = Field(1.0, gt=0)
    boundary: Literal["fixed", "periodic", "free"] = "fixed"
    dampers: ChainDampers | None = None
    eps: FiniteFloat = Field(1.0, ge=0, description="damping strength (D is scaled by it)")
    on_site: ChainOnSiteInput | None = Field(None, description="an on-site potential on every site (Klein-Gordon, "
                                                               "Frenkel-Kontorova); none by default")

    def files(self, at: tuple) -> Iterator[tuple[tuple, str, str]]:
        return iter(())

    def sizes(self, at: tuple) -> Iterator[tuple[tuple, str, int]]:
        return iter(())  # a chain's state is built from its description, not sent

    def compiles(self) -> bool:
        return self.bond == "expression"

    def compiled_form(self) -> tuple[str, bytes] | None:
        return None

    def names(self, dim: int, momenta: int, save_dofs: list[int] | None) -> tuple[list[str], list[str]]:
        return _site_names(dim, momenta, save_dofs)

    def build(self, files: FileResolver | None = None):
        from ..systems.chain import Chain

        try:
            return Chain.from_dict(self.model_dump(exclude_none=True))
        except ValueError as error:
            raise path_error(error, type(self)) from None


# ---- orbits: raydamp.Kepler.to_dict()'s form ------------------------------------------------------

MAX_KEPLER_PARTICLES = 10**6
_DragRow = bounded(FiniteFloat, 3, min_length=2)
DragDirection = Annotated[Annotated[Literal["isotropic", "radial", "tangential"], Tag("direction form")]
                          | Annotated[bounded(_DragRow, 3, min_length=2), Tag("matrix form")],
                          Discriminator(lambda value: "matrix form" if isinstance(value, list) else "direction form")]
DRAG_DESCRIPTION = ("the drag's direction: the whole momentum (isotropic), its part along the radius vector "
                    "(radial: no torque, L conserved) or across it (tangential); or a dim x dim symmetric positive "
                    "semi-definite matrix A of fixed axes, p' = ... - eps A p ([[0,0,0],[0,0,0],[0,0,1]] damps the "
                    "vertical momentum alone)")


class KeplerInput(SystemKind):
    """Test particles around a fixed central body with linear drag, stepped with the exact Kepler drift:
    raydamp.Kepler.to_dict()'s form (raydamp.systems.kepler documents it)."""

    kind: Literal["kepler"]
    mu: FiniteFloat = Field(1.0, gt=0, description="G times the central mass")
    mass: FiniteFloat = Field(1.0, gt=0, description="each particle's mass")
    dim: Literal[2, 3] = Field(2, description="2 or 3 dimensions")
    particles: int = Field(1, ge=1, le=MAX_KEPLER_PARTICLES, description="number of test particles")
    eps: FiniteFloat = Field(0.0, ge=0, description="drag rate: p' = -grad H - eps p")
    drag: DragDirection = Field("isotropic", description=DRAG_DESCRIPTION)

    def names(self, dim: int, momenta: int, save_dofs: list[int] | None) -> tuple[list[str], list[str]]:
        axes = "xyz"[: self.dim]
        coordinates = [f"{a}{i}" for i in range(self.particles) for a in axes]
        chosen = [coordinates[i] for i in save_dofs] if save_dofs is not None else coordinates
        return chosen, (["L"] if self.dim == 2 else ["Lx", "Ly", "Lz"])[:momenta]

    def build(self, files: FileResolver | None = None):
        from ..systems.kepler import Kepler

        try:
            return Kepler.from_dict(self.model_dump(exclude_none=True))
        except ValueError as error:
            raise path_error(error, type(self)) from None


# ---- interacting planets: raydamp.Planets.to_dict()'s form ----------------------------------------

MAX_PLANETS = 1000  # raydamp.systems.planets.MAX_PLANETS: the interaction is O(N^2) per kick
_Drag = Annotated[FiniteFloat, Field(ge=0)]
PlanetDrag = Annotated[Annotated[_Drag, Tag("number form")]
                       | Annotated[bounded(_Drag, MAX_PLANETS, min_length=1), Tag("vector form")],
                       Discriminator(lambda value: "vector form" if isinstance(value, list) else "number form")]


class PlanetsInput(SystemKind):
    """Interacting planets around a central body in Jacobi coordinates, drag on chosen planets, stepped with
    the exact Kepler drift: raydamp.Planets.to_dict()'s form (raydamp.systems.planets documents it). The
    initial state's q and p are Jacobi coordinates (Planets.jacobi_state makes them)."""

    kind: Literal["planets"]
    masses: bounded(Annotated[FiniteFloat, Field(gt=0)], MAX_PLANETS, min_length=1) = Field(
        description="the planets' masses, inner to outer")
    central_mass: FiniteFloat = Field(1.0, gt=0, description="the central body's mass")
    G: FiniteFloat = Field(1.0, gt=0, description="the gravitational constant")
    dim: Literal[2, 3] = Field(2, description="2 or 3 dimensions")
    eps: PlanetDrag = Field(0.0, description="drag rate, one for every planet or one per planet: "
                                             "P_i' = -grad_i H - eps_i P_i")
    drag: DragDirection = Field("isotropic", description=DRAG_DESCRIPTION)

    def names(self, dim: int, momenta: int, save_dofs: list[int] | None) -> tuple[list[str], list[str]]:
        axes = "xyz"[: self.dim]
        coordinates = [f"{a}{i}" for i in range(len(self.masses)) for a in axes]
        chosen = [coordinates[i] for i in save_dofs] if save_dofs is not None else coordinates
        return chosen, (["L"] if self.dim == 2 else ["Lx", "Ly", "Lz"])[:momenta]

    def build(self, files: FileResolver | None = None):
        from ..systems.planets import Planets

        try:
            return Planets.from_dict(self.model_dump(exclude_none=True))
        except ValueError as error:
            raise path_error(error, type(self)) from None


# ---- linear structures: raydamp.LinearStructure.to_dict()'s form, with uploaded files -------------

MAX_COO_ENTRIES = 1_000_000  # raydamp.structure.MAX_PLAIN_ENTRIES; a service's max_structure_nnz is at most this
MAX_STRUCTURE_DIM = 10**7  # a service's max_structure_dim is at most this


class CooMatrix(Input):
    shape: bounded(Annotated[int, Field(ge=1, le=MAX_STRUCTURE_DIM)], 2, min_length=2) = Field(description="[n, n]")
    rows: bounded(Annotated[int, Field(ge=0)], MAX_COO_ENTRIES, items=indices(MAX_COO_ENTRIES)) = Field(
        description="row of each entry")
    cols: bounded(Annotated[int, Field(ge=0)], MAX_COO_ENTRIES, items=indices(MAX_COO_ENTRIES)) = Field(
        description="column of each entry")
    values: bounded(FiniteFloat, MAX_COO_ENTRIES, items=numbers(MAX_COO_ENTRIES)) = Field(
        description="the entries (repeated positions add up)")


class CooForm(Input):
    coo: CooMatrix


class DiagonalForm(Input):
    diagonal: bounded(FiniteFloat, MAX_STRUCTURE_DIM, min_length=1, items=numbers(MAX_STRUCTURE_DIM)) = Field(
        description="a diagonal matrix (lumped mass)")


class FileForm(Input):
    file: MatrixFile


# The tags are not key names: "K" followed by "coo" in a loc is then always the client's key (our own
# checks' locs carry no tags), and "K" followed by "coo form" is pydantic's tag, dropped from a 422.
def _matrix_form(value: object) -> str | None:
    if isinstance(value, dict):
        for key in ("coo", "file", "diagonal"):
            if key in value:
                return f"{key} form"
        return None  # none of the forms: one error saying which there are
    for form, name in ((CooForm, "coo"), (FileForm, "file"), (DiagonalForm, "diagonal")):
        if isinstance(value, form):
            return f"{name} form"
    return None


MatrixInput = Annotated[Annotated[CooForm, Tag("coo form")] | Annotated[DiagonalForm, Tag("diagonal form")]
                        | Annotated[FileForm, Tag("file form")],
                        Discriminator(_matrix_form, custom_error_type="matrix_form",
                                      custom_error_message='a matrix is {"coo": {"shape", "rows", "cols", "values"}}, '
                                                           '{"diagonal": [...]} or {"file": "<id from POST '
                                                           '/v1/files>"}')]


class LinearStructureInput(SystemKind):
    """A linear structure M q'' + (alpha M + beta K) q' + K q = f: raydamp.LinearStructure.to_dict()'s
    form, with a matrix also given as {"file": id} of an uploaded Matrix Market file. M symmetric
    positive definite (a diagonal M is a lumped mass), K symmetric positive semi-definite (both
    checked: both triangles compared, and K's inertia; allow_indefinite_stiffness accepts an indefinite K)."""

    kind: Literal["linear_structure"]
    M: MatrixInput = Field(description='{"coo": {shape, rows, cols, values}}, {"diagonal": [...]} or {"file": id}')
    K: MatrixInput = Field(description="the stiffness matrix, in the same forms as M")
    alpha: FiniteFloat = Field(0.0, ge=0, description="Rayleigh damping C = alpha M + beta K")
    beta: FiniteFloat = Field(0.0, ge=0)
    f: bounded(FiniteFloat, MAX_STRUCTURE_DIM, items=numbers(MAX_STRUCTURE_DIM)) | None = Field(
        None, description="constant load (length n); null for none")
    allow_indefinite_stiffness: bool = Field(False, description="accept a K that is not positive semi-definite (a "
                                                                "structure meant to grow); by default it is refused")

    def files(self, at: tuple) -> Iterator[tuple[tuple, str, str]]:
        """(JSON path, "id" or "path", the reference) of each matrix given as {"file": ...}."""
        for key in ("M", "K"):
            form = getattr(self, key)
            if isinstance(form, FileForm):
                yield (*at, key, "file"), "id" if FILE_ID.match(form.file) else "path", form.file

    def sizes(self, at: tuple) -> Iterator[tuple[tuple, str, int]]:
        """(path, "entries", count) of each COO list, (path, "coordinates", n) of each matrix given inline."""
        for key in ("M", "K"):
            form = getattr(self, key)
            if isinstance(form, CooForm):
                for name in ("rows", "cols", "values"):
                    yield (*at, key, "coo", name), "entries", len(getattr(form.coo, name))
                yield (*at, key, "coo", "shape"), "coordinates", form.coo.shape[0]
            elif isinstance(form, DiagonalForm):
                yield (*at, key, "diagonal"), "coordinates", len(form.diagonal)

    def compiles(self) -> bool:
        return False

    def compiled_form(self) -> tuple[str, bytes] | None:
        return None

    def names(self, dim: int, momenta: int, save_dofs: list[int] | None) -> tuple[list[str], list[str]]:
        return _site_names(dim, momenta, save_dofs)

    def build(self, files: FileResolver | None = None):
        """raydamp builds and checks the structure (indices, shapes, symmetry and definiteness);
        files(id) opens an uploaded file (a service's store); without it a {"file": ...} is a path."""
        from ..systems.structure import LinearStructure

        try:
            return LinearStructure.from_dict(self.model_dump(exclude_none=True), files=files or _local_files)
        except ValueError as error:
            raise path_error(error, type(self)) from None


# ---- structures with hysteretic springs: raydamp.Structure.to_dict()'s form ----------------------------

class ElasticPlasticForm(Input):
    kind: Literal["elastic_plastic"]
    k: FiniteFloat = Field(gt=0, description="the initial stiffness")
    fy: FiniteFloat = Field(gt=0, description="the yield force")


class BilinearForm(Input):
    kind: Literal["bilinear"]
    k: FiniteFloat = Field(gt=0, description="the initial stiffness")
    fy: FiniteFloat = Field(gt=0, description="the yield force")
    b: FiniteFloat = Field(0.0, gt=-1, lt=1, description="the post-yield stiffness ratio: [0, 1) hardens, "
                                                          "(-1, 0) softens")


class BoucWenForm(Input):
    kind: Literal["bouc_wen"]
    k: FiniteFloat = Field(gt=0, description="the initial stiffness")
    fy: FiniteFloat = Field(gt=0, description="the yield force")
    alpha: FiniteFloat = Field(0.0, ge=0, lt=1, description="the post-yield stiffness ratio")
    n: Literal[1] = Field(1, description="the exponent (only 1: its evolution has a closed form)")
    beta: FiniteFloat = Field(0.5, gt=0, description="beta > 0 and beta + gamma > 0 bound the hysteresis")
    gamma: FiniteFloat = 0.5


MaterialInput = Annotated[ElasticPlasticForm | BilinearForm | BoucWenForm, Field(discriminator="kind")]


# A job's springs are objects of some 60 bytes and more: a bound below what a body can carry makes a long list of
# bad items one length error, read before its items (a list as long as a structure's would be read item by item).
MAX_SPRINGS = 10_000


class SpringInput(Input):
    dofs: bounded(Annotated[int, Field(ge=0)], 2, min_length=1) = Field(
        description="[j]: d = q_j (to the ground); [i, j]: d = q_j - q_i")
    material: MaterialInput


class StructureInput(LinearStructureInput):
    """A structure with hysteretic springs: raydamp.Structure.to_dict()'s form. K (optional) is the linear
    stiffness besides the springs; C = alpha M + beta K0 with K0 = K + the springs' initial stiffness."""

    kind: Literal["structure"]
    K: MatrixInput | None = Field(None, description="the linear stiffness besides the springs; null for none")
    springs: bounded(SpringInput, MAX_SPRINGS) = Field(
        default_factory=list, description='[{"dofs": [i, j], "material": {"kind": "bilinear", "k", "fy", "b"}}]; at '
                                          f'most {MAX_SPRINGS:,} in a job (raydamp.Structure has no such bound)')
    locate_kinks: bool = Field(False, description="split each step at the springs' and the load's kinks, so that "
                                                  "every method keeps its order (help(raydamp.Structure))")
    damping_stiffness: Literal["initial", "tangent"] = Field(
        "initial", description="Rayleigh's stiffness: the initial K0, or each spring's tangent on its branch "
                               "(help(raydamp.Structure))")

    def files(self, at: tuple) -> Iterator[tuple[tuple, str, str]]:
        for key in ("M", "K"):
            form = getattr(self, key)
            if isinstance(form, FileForm):
                yield (*at, key, "file"), "id" if FILE_ID.match(form.file) else "path", form.file

    def build(self, files: FileResolver | None = None):
        from ..systems.yielding import Structure

        try:
            return Structure.from_dict(self.model_dump(exclude_none=True), files=files or _local_files)
        except ValueError as error:
            raise path_error(error, type(self)) from None


def _site_names(dim: int, momenta: int, save_dofs: list[int] | None) -> tuple[list[str], list[str]]:
    # Sites or degrees of freedom are numbered; the total momentum P is the one momentum map a chain
    # may have, and a structure has none.
    return [f"q{i}" for i in (save_dofs if save_dofs is not None else range(dim))], ["P"] * momenta


def _local_files(ref: str) -> Any:
    # Without a store (raydamp run), a {"file": ...} is a Matrix Market path; an upload's id names nothing.
    # A service refuses paths before any model is built (JobSpec.local_path), with or without its store.
    if FILE_ID.match(ref):
        raise ValueError(f"no uploaded file with id {ref!r} (without a service, give the Matrix Market file's path)")
    return ref


def _system_form(value: object) -> str:
    kind = value.get("kind") if isinstance(value, dict) else getattr(value, "kind", None)
    return kind if kind in ("chain", "linear_structure", "structure", "kepler", "planets") else "expressions"


MATRIX_TAGS = frozenset({"coo form", "diagonal form", "file form"})
SYSTEM_TAGS = frozenset({"expressions", "chain", "linear_structure", "structure", "kepler", "planets"})
# Tags name forms, never keys: a path of ours ("damping", "dampers", 0, "on") keeps every part.
FORM_TAGS = {"damping": frozenset({"scalar form", "diagonal form", "matrix form", "dampers form"}),
             "coordinates": frozenset({"names form", "count form"}),
             "mass": frozenset({"number form", "vector form", "matrix form"}),
             "c": frozenset({"number form", "vector form"}),
             "eps": frozenset({"number form", "vector form"}),
             "drag": frozenset({"direction form", "matrix form"}),
             "material": frozenset({"elastic_plastic", "bilinear", "bouc_wen"})}
VALUE_TAGS = frozenset({"number form", "expression form", "vector form"})  # after a parameter's name
AnySystemInput = Annotated[Annotated[SystemInput, Tag("expressions")] | Annotated[ChainInput, Tag("chain")]
                           | Annotated[LinearStructureInput, Tag("linear_structure")]
                           | Annotated[StructureInput, Tag("structure")]
                           | Annotated[KeplerInput, Tag("kepler")]
                           | Annotated[PlanetsInput, Tag("planets")], Discriminator(_system_form)]
