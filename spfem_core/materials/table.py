"""The rows of material constants a simulation reads: one per material, or one per particle.

A row has a model (``materials.MODELS``), the elastic constants every model shares (density,
Young's modulus, Poisson's ratio) and the properties its model declares (``<model>.PROPERTIES``),
each stored as a float64 column over all rows (NaN in the rows of models without it).  A scene
whose properties vary from particle to particle gives the simulation a table with a row per
particle (``Scene.particle_materials``); the kernels read row ``material_row[k]`` of particle k
either way, so a scene without such properties pays nothing for them.

The kernels read the constants of every model from one (n_rows, width) array
(:meth:`MaterialTable.kernel_constants`): each model fills its own named columns (``<model>.CONSTANTS``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from spfem_core.materials import MODEL_CODES, MODELS, elastic

ELASTIC_COLUMNS = ("density_kg_m3", "youngs_modulus_pa", "poisson_ratio")
"""The columns every row has, whatever its model."""

PROPERTY_MODELS = {prop.name: prop for model in MODELS for prop in model.PROPERTIES}
"""Every property a model declares, by name (a name means one thing in every model that has it)."""


def _column(values, n: int, what: str) -> np.ndarray:
    column = np.ascontiguousarray(values, dtype=np.float64).reshape(-1)
    if column.shape != (n,):
        raise ValueError(f"MaterialTable.{what}: expected {n} values, got {column.shape[0]}")
    return column


def _property_column(name: str, values, n: int) -> np.ndarray:
    """The float64 column of property ``name``: numbers as they are, choices (names) by their index,
    None as NaN."""
    raw = np.asarray(values, dtype=object if isinstance(values, (list, tuple)) else None)
    if raw.dtype.kind not in "fiub":
        prop = PROPERTY_MODELS[name]
        raw = [np.nan if v is None else prop.encode(v) for v in raw.ravel()]
    return _column(raw, n, name)


@dataclass(frozen=True, eq=False)
class MaterialTable:
    """Rows of material constants (module doc); a particle refers to a row by its ``material_row``.

    ``model`` holds the code of each row's model (names are accepted and converted);
    ``properties`` maps a property name to a column of ``n_rows`` values (categorical ones as
    their names or indices; NaN or absent: the model's default, an error where it has none).
    """

    name: tuple[str, ...]
    model: np.ndarray  # (n_rows,) int64 codes of materials.MODELS
    density_kg_m3: np.ndarray  # (n_rows,) mass density rho
    youngs_modulus_pa: np.ndarray  # (n_rows,) E
    poisson_ratio: np.ndarray  # (n_rows,) nu
    properties: Mapping[str, np.ndarray] = field(default_factory=dict)  # name -> (n_rows,) float64

    def __post_init__(self):
        names = tuple(self.name)
        n = len(names)
        object.__setattr__(self, "name", names)
        given = np.asarray(self.model).reshape(-1)
        if given.dtype.kind in "iu":  # codes already (a table of a row per particle: no loop over them)
            model = np.ascontiguousarray(given, dtype=np.int64)
        else:
            model = np.ascontiguousarray([MODEL_CODES.get(m, -1) if isinstance(m, str) else int(m) for m in given],
                                         dtype=np.int64)
        if model.shape != (n,):
            raise ValueError(f"MaterialTable.model: expected {n} values, got {model.shape[0]}")
        if n and (model.min() < 0 or model.max() >= len(MODELS)):
            raise ValueError(f"MaterialTable.model: must be one of {list(MODEL_CODES)}, got {list(self.model)}")
        object.__setattr__(self, "model", model)
        for what in ELASTIC_COLUMNS:
            object.__setattr__(self, what, _column(getattr(self, what), n, what))
        if not np.all((self.density_kg_m3 > 0.0) & (self.youngs_modulus_pa > 0.0) & (self.poisson_ratio >= 0.0)
                      & (self.poisson_ratio < 0.5)):
            raise ValueError("MaterialTable: densities and Young's moduli must be > 0, Poisson's ratios in [0, 0.5)")
        unknown = sorted(set(self.properties) - set(PROPERTY_MODELS))
        if unknown:
            raise ValueError(f"MaterialTable.properties: no model has {unknown[0]!r} "
                             f"(known: {sorted(PROPERTY_MODELS)})")
        columns = {name: _property_column(name, values, n) for name, values in self.properties.items()}
        for material_model in MODELS:
            rows = model == material_model.CODE
            if rows.any():
                self._fill_and_check(material_model, rows, columns)
        object.__setattr__(self, "properties", columns)

    def _fill_and_check(self, material_model, rows: np.ndarray, columns: dict) -> None:
        """Fill the defaults of ``material_model``'s properties in its ``rows`` and check them."""
        n = len(self.name)
        for prop in material_model.PROPERTIES:
            column = columns.setdefault(prop.name, np.full(n, np.nan))
            missing = rows & np.isnan(column)
            if missing.any() and prop.default is None:
                row = int(np.flatnonzero(missing)[0])
                raise ValueError(f"MaterialTable.{prop.name}: material {self.name[row]!r} ({material_model.NAME}) "
                                 "needs it")
            column[missing] = prop.default
            given = np.flatnonzero(rows & ~np.isnan(column))  # NaN left: a default of NaN (the model decides)
            problem = prop.problem(column[given])
            if problem is not None:
                row = int(given[problem[0]])
                raise ValueError(f"MaterialTable.{prop.name}: material {self.name[row]!r}: {problem[1]}, "
                                 f"got {column[row]!r}")
        problem = material_model.check(self._model_properties(material_model, rows, columns))
        if problem is not None:
            raise ValueError(f"MaterialTable.{problem} ({material_model.NAME})")

    @staticmethod
    def _model_properties(material_model, rows: np.ndarray, columns: Mapping[str, np.ndarray]) -> dict:
        """The columns of ``material_model``'s properties at ``rows``."""
        return {prop.name: columns[prop.name][rows] for prop in material_model.PROPERTIES}

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_rows(cls, rows: Sequence[Mapping]) -> MaterialTable:
        """A table from one mapping per row: ``name``, ``model``, the elastic columns and the
        row's properties (absent ones: NaN, the model's default)."""
        names = sorted({key for row in rows for key in row} - {"name", "model", *ELASTIC_COLUMNS})
        return cls(tuple(row["name"] for row in rows), [row["model"] for row in rows],
                   *([row[column] for row in rows] for column in ELASTIC_COLUMNS),
                   {key: [row.get(key, np.nan) for row in rows] for key in names})

    @classmethod
    def elastic(cls, name: str, density_kg_m3: float, youngs_modulus_pa: float, poisson_ratio: float):
        """A table with a single linear elastic material."""
        return cls((name,), [elastic.CODE], [density_kg_m3], [youngs_modulus_pa], [poisson_ratio])

    @classmethod
    def single(cls, name, model, density_kg_m3, youngs_modulus_pa, poisson_ratio, cohesion_pa=None,
               friction_deg=None, dilation_deg=None, **properties):
        """A table with one material of ``model`` (a name of ``materials.MODELS``); the strength
        c, phi, psi of a frictional model may be given by position."""
        strength = {"cohesion_pa": cohesion_pa, "friction_deg": friction_deg, "dilation_deg": dilation_deg}
        given = {key: [value] for key, value in (strength | properties).items() if value is not None}
        return cls((name,), [model], [density_kg_m3], [youngs_modulus_pa], [poisson_ratio], given)

    def rows(self, index: np.ndarray) -> MaterialTable:
        """The table of rows ``index`` (a row may come several times): a row per particle."""
        index = np.asarray(index, dtype=np.int64)
        return MaterialTable(tuple(self.name[i] for i in index), self.model[index],
                             *(getattr(self, column)[index] for column in ELASTIC_COLUMNS),
                             {key: column[index] for key, column in self.properties.items()})

    def with_values(self, values: Mapping[str, np.ndarray]) -> MaterialTable:
        """The table with the columns of ``values`` replaced where they are not NaN (elastic
        columns or properties, one value per row); checked as any table is."""
        elastic_values = {key: np.where(np.isnan(v := _column(values[key], self.n_rows, key)), getattr(self, key), v)
                          for key in ELASTIC_COLUMNS if key in values}
        properties = dict(self.properties)
        for key in set(values) - set(ELASTIC_COLUMNS):
            given = _column(values[key], self.n_rows, key)
            properties[key] = np.where(np.isnan(given), properties.get(key, np.full(self.n_rows, np.nan)), given)
        return dataclasses.replace(self, properties=properties, **elastic_values)

    # ------------------------------------------------------------------ views
    @property
    def n_rows(self) -> int:
        return len(self.name)

    @property
    def shear_modulus_pa(self) -> np.ndarray:
        """G = E / (2 (1 + nu))."""
        return self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def bulk_modulus_pa(self) -> np.ndarray:
        """K = E / (3 (1 - 2 nu))."""
        return self.youngs_modulus_pa / (3.0 * (1.0 - 2.0 * self.poisson_ratio))

    @property
    def lame_lambda_pa(self) -> np.ndarray:
        """lambda = K - 2G/3."""
        return self.bulk_modulus_pa - 2.0 * self.shear_modulus_pa / 3.0

    @property
    def p_wave_speed_m_s(self) -> np.ndarray:
        """c_p = sqrt((K + 4G/3) / rho), the fastest wave of the material."""
        return np.sqrt((self.bulk_modulus_pa + 4.0 * self.shear_modulus_pa / 3.0) / self.density_kg_m3)

    @property
    def plastic(self) -> bool:
        """Whether any row has a plastic model."""
        return bool(np.any(self.model != elastic.CODE))

    def kernel_constants(self) -> np.ndarray:
        """(n_rows, width) constants the compiled update reads: each model's ``CONSTANTS`` in its
        rows (module doc); width: the most any model of the table has (at least 1)."""
        present = [m for m in MODELS if np.any(self.model == m.CODE)]
        params = np.zeros((self.n_rows, max([len(m.CONSTANTS) for m in present] + [1])))
        for material_model in present:
            rows = self.model == material_model.CODE
            values = material_model.constants(self._model_properties(material_model, rows, self.properties),
                                              int(rows.sum()))
            for column, value in enumerate(values):
                params[rows, column] = value
        return params

    # ------------------------------------------------------------------ derived tables
    def with_strength_reduction(self, srf: float, associated: bool = False) -> MaterialTable:
        """Strength divided by ``srf`` as each row's model says (``<model>.reduced``): c / F and
        tan(phi) / F with psi_F = min(psi, phi_F), or psi_F = phi_F with ``associated`` (normality:
        the flow rule under which limit equilibrium and limit analysis give the factor of safety)."""
        if not srf > 0:
            raise ValueError(f"srf: must be > 0, got {srf}")
        properties = {key: column.copy() for key, column in self.properties.items()}
        for material_model in MODELS:
            rows = self.model == material_model.CODE
            if rows.any():
                reduced = material_model.reduced(self._model_properties(material_model, rows, self.properties),
                                                 float(srf), associated)
                for key, values in reduced.items():
                    properties[key][rows] = values
        return dataclasses.replace(self, properties=properties)

    def slip_strength(self) -> tuple[np.ndarray, np.ndarray]:
        """(c, tan phi) per row of a support the soil slides along (``<model>.slip_strength``): the
        shear strength tau = c + sigma_n tan(phi) of each row (c = inf for a row that cannot slide)."""
        cohesion, tan_friction = np.full(self.n_rows, np.inf), np.zeros(self.n_rows)
        for material_model in MODELS:
            rows = self.model == material_model.CODE
            if rows.any():
                cohesion[rows], tan_friction[rows] = material_model.slip_strength(
                    self._model_properties(material_model, rows, self.properties), int(rows.sum()))
        return cohesion, tan_friction

    def with_moduli_scaled(self, factor: float) -> MaterialTable:
        """Every Young's modulus times ``factor`` (Poisson's ratios kept): in small-strain theory the
        elastic-plastic stresses of a body under given loads do not change and its displacements
        are divided by ``factor``."""
        if not factor > 0:
            raise ValueError(f"factor: must be > 0, got {factor}")
        return dataclasses.replace(self, youngs_modulus_pa=self.youngs_modulus_pa * float(factor))

    def softens(self) -> bool:
        """Whether any row's strength falls with plastic strain (a softening law other than none)."""
        law = self.properties.get("softening_law")
        return law is not None and bool(np.any(np.nan_to_num(law) > 0))

    def as_elastic(self) -> MaterialTable:
        """The same table with every material linear elastic (e.g. for a gravity stage)."""
        return dataclasses.replace(self, model=np.full(self.n_rows, elastic.CODE, dtype=np.int64))
