"""A pension fund described in files: a YAML fund file (market, assets, objective, effects) that
names a liability CSV (`_liability_file.py`). `snapo alm --fund FILE` and `load_fund` read them;
the built-in fund ships as `finance/data/alm_fund.yaml` (`sample_fund_path`).

Units: rates, spreads and volatilities per year as fractions (0.02 = 2%), continuously
compounded zero rates; maturities and tenors in years; money in millions of the fund's currency
unless the file names another unit (`holdings_unit`, the liability file's `cash_flow_unit`).
Types and the file's structure are checked here (file, line, field, value, what is allowed);
ranges by the model's own checks (`Market`, `check_factors`, `ALMConfig`), the same as for
Python callers.
"""

import datetime
import os
import pathlib
from importlib.resources import files
from typing import NamedTuple

import numpy as np
import pydantic

from snapo_ode import STRICT_SCHEMA, FiniteNumber, InputError, read_text, strict_yaml, validate

from ._assets import initial_prices
from ._board import BoardSettings
from ._factors import DEFAULT_MIX, holdings_at_funding_ratio
from ._liabilities import LiabilitySchedule
from ._liability_file import load_liabilities
from ._market import ASSETS, AssetClass, Market, check_asset_classes
from ._model import EFFECTS, MAX_HORIZON_MONTHS, ALMConfig, indexed_share
from ._units import in_millions

Numbers = list[FiniteNumber]
Name = pydantic.constr(pattern=r"^[A-Za-z][A-Za-z0-9_]{0,39}$")  # a factor name's part: letters, digits, _
Bounds = pydantic.conlist(FiniteNumber, min_length=2, max_length=2)


class _Section(pydantic.BaseModel):
    model_config = STRICT_SCHEMA


class Equity(_Section):
    """One equity index: its `name`, `level` (index points at the start) and `volatility` [1/sqrt(year)]."""

    name: Name
    level: FiniteNumber = 1.0
    volatility: FiniteNumber


class MarketSection(_Section):
    """The scenario generator's inputs (`Market` and the market factor groups)."""

    key_tenors: Numbers
    key_rates: Numbers
    rate_vols: Numbers
    rate_mean_reversion: FiniteNumber = 0.1
    inflation: FiniteNumber
    inflation_vol: FiniteNumber
    inflation_mean_reversion: FiniteNumber = 0.5
    spread: FiniteNumber
    spread_vol: FiniteNumber
    spread_mean_reversion: FiniteNumber = 0.8
    equity_premium: FiniteNumber = 0.04
    equities: pydantic.conlist(Equity, min_length=1, max_length=50)
    correlation: list[Numbers] | None = None


class LiabilitiesSection(_Section):
    """The liability CSV (`file`, relative to the fund file), the unit of its cash flows and,
    for a `date` column, the valuation date."""

    file: str
    cash_flow_unit: str = "million / month"
    valuation_date: datetime.date | None = None


class AssetClassEntry(_Section):
    """One asset class: `name`, `kind` (cash, nominal, inflation_linked, credit, equity) and, for
    the bond kinds, `maturity` [years] or, the same for the zero-coupon buckets the model holds,
    `duration` [years] (`AssetClass`)."""

    name: Name
    kind: str
    maturity: FiniteNumber | None = None
    duration: FiniteNumber | None = None

    @pydantic.model_validator(mode="after")
    def _one_of_maturity_and_duration(self):
        if self.maturity is not None and self.duration is not None:
            raise ValueError("give maturity or duration, not both (a zero-coupon bucket's duration is its maturity)")
        return self


class AssetsSection(_Section):
    """The asset classes' maturities, weight bounds, and the starting holdings: either
    `classes`, the asset classes the policy weights (default the built-in six, `ASSETS`, at
    `bond_maturities`, `inflation_linked_maturity` and `credit_maturity`), and either
    `initial_funding_ratio` with the `mix` of the asset classes' values (keys the class names, summing to
    1), or `holdings`, each asset's market value (cash, the four bond buckets and each equity
    index by name) in `holdings_unit`. The funding ratio values the liabilities as the
    simulation does at the start, with the study's effects (the indexed share of the benefits,
    the credit bucket's spread) on its initial market (the file's, or a scenario set's start)."""

    bond_maturities: Bounds = (5.0, 30.0)
    inflation_linked_maturity: FiniteNumber = 20.0
    credit_maturity: FiniteNumber = 7.0
    credit_loss_fraction: FiniteNumber = 0.4
    classes: list[AssetClassEntry] | None = None
    weight_bounds: dict[str, Bounds] | None = None
    initial_funding_ratio: FiniteNumber | None = None
    mix: dict[str, FiniteNumber] | None = None
    holdings: dict[str, FiniteNumber] | None = None
    holdings_unit: str = "million"


class ObjectiveSection(_Section):
    """`ALMConfig`'s fields (the objective's parameters and the effects'); omitted ones keep
    their defaults."""

    transaction_cost: FiniteNumber | None = None
    indexation: FiniteNumber | None = None
    contribution: FiniteNumber | None = None
    funding_floor: FiniteNumber | None = None
    floor_penalty: FiniteNumber | None = None
    risk_aversion: FiniteNumber | None = None
    shortfall_measure: str | None = None
    max_turnover: FiniteNumber | None = None
    turnover_sharpness: FiniteNumber | None = None
    floor_sharpness: FiniteNumber | None = None


class BoardSection(_Section):
    """Where the board's figures are taken (`BoardSettings`): `required_funding_ratio`, the
    `months` of the date figures, the `confidence` of surplus at risk."""

    required_funding_ratio: FiniteNumber = 1.25
    months: list[pydantic.StrictInt] | None = None
    confidence: FiniteNumber = 0.95


class FundFile(_Section):
    """A fund file (docs/alm.md, "A fund in files")."""

    name: str
    currency: str = "EUR"
    horizon_months: pydantic.conint(strict=True, ge=1, le=MAX_HORIZON_MONTHS) = 120
    effects: list[str] | None = None
    market: MarketSection
    liabilities: LiabilitiesSection
    assets: AssetsSection
    objective: ObjectiveSection = ObjectiveSection()
    board: BoardSection = BoardSection()


class Fund(NamedTuple):
    """A fund ready to study (`build_fund_study`): its `name`, `market`, every factor group but
    the holdings `factors` (float64 arrays), the liability `schedule`, the `config`,
    `horizon_months`, the `effects` it names (None: all), its `assets` section (the holdings
    follow from it once the study's initial market and effects are known: `fund_holdings`), its
    `board` settings, and the `files` it was read from (the fund file, then the liability file;
    reports record their SHA-256)."""

    name: str
    market: Market
    factors: dict
    schedule: LiabilitySchedule
    config: ALMConfig
    horizon_months: int
    effects: tuple[str, ...] | None
    assets: AssetsSection
    board: BoardSettings = BoardSettings()
    files: tuple[pathlib.Path, ...] = ()


def _keys(where: str, field: str, given: dict, allowed: tuple[str, ...]) -> None:
    unknown = [key for key in given if key not in allowed]
    missing = [key for key in allowed if key not in given]
    if unknown or missing:
        raise InputError(f"{where}: {field} has {'unknown ' + repr(unknown) if unknown else ''}"
                         f"{' and ' if unknown and missing else ''}{'no ' + repr(missing) if missing else ''}; "
                         f"its keys are {', '.join(allowed)}.")


def _market(section: MarketSection, assets: AssetsSection, where: str) -> Market:
    classes = None if assets.classes is None else tuple(
        AssetClass(c.name, c.kind, c.maturity if c.duration is None else c.duration) for c in assets.classes)
    both = {"bond_maturities", "inflation_linked_maturity", "credit_maturity"} & assets.model_fields_set
    if classes is not None and both:
        raise InputError(f"{where}: assets.{sorted(both)[0]} with assets.classes: the classes carry their own "
                         "maturities; give one of the two.")
    try:
        names = ASSETS if classes is None else tuple(c.name for c in check_asset_classes(classes))
    except InputError as error:
        raise InputError(f"{where}: assets.classes: {error}") from None
    bounds = {}
    if assets.weight_bounds is not None:
        _keys(where, "assets.weight_bounds", assets.weight_bounds, names)
        bounds = dict(weight_low=tuple(assets.weight_bounds[a][0] for a in names),
                      weight_high=tuple(assets.weight_bounds[a][1] for a in names))
    try:
        return Market(np.asarray(section.key_tenors, float), len(section.equities),
                      correlation=None if section.correlation is None else np.asarray(section.correlation, float),
                      rate_mean_reversion=section.rate_mean_reversion,
                      inflation_mean_reversion=section.inflation_mean_reversion,
                      spread_mean_reversion=section.spread_mean_reversion, equity_premium=section.equity_premium,
                      bond_maturities=tuple(assets.bond_maturities),
                      inflation_linked_maturity=assets.inflation_linked_maturity,
                      credit_maturity=assets.credit_maturity, credit_loss_fraction=assets.credit_loss_fraction,
                      equity_names=tuple(e.name for e in section.equities), asset_classes=classes, **bounds)
    except InputError as error:
        raise InputError(f"{where}: {error}") from None


def _check_assets(assets: AssetsSection, market: Market, where: str) -> None:
    if (assets.holdings is None) == (assets.initial_funding_ratio is None):
        raise InputError(f"{where}: assets needs exactly one of initial_funding_ratio (with mix) and holdings.")
    if assets.holdings is not None:
        _keys(where, "assets.holdings", assets.holdings, (*market.asset_names[:-1], *market.equity_names))
        in_millions(assets.holdings_unit, f"{where}: assets.holdings_unit")
        return
    mix = DEFAULT_MIX if assets.mix is None else assets.mix
    if assets.mix is None and market.asset_names != ASSETS:
        raise InputError(f"{where}: assets.mix is needed for the asset classes {list(market.asset_names)}.")
    _keys(where, "assets.mix", mix, market.asset_names)
    if min(mix.values()) < 0 or abs(sum(mix.values()) - 1.0) > 1e-9:
        raise InputError(f"{where}: assets.mix = {mix}; allowed: weights >= 0 summing to 1.")
    if not 0.0 < assets.initial_funding_ratio <= 10.0:
        raise InputError(f"{where}: assets.initial_funding_ratio = {assets.initial_funding_ratio}; allowed: (0, 10].")


def fund_holdings(fund: Fund, factors: dict, scene) -> np.ndarray:
    """The units the fund holds (`holdings`), from its `assets` section: its holdings' money
    values at the initial prices, or its initial funding ratio and mix, the liabilities valued as
    the simulation values them under `scene` on the initial market of `factors`."""
    assets, market = fund.assets, fund.market
    if assets.holdings is not None:
        names = (*market.asset_names[:-1], *market.equity_names)
        values = np.array([assets.holdings[name] for name in names]) * in_millions(assets.holdings_unit, "holdings_unit")
        prices = initial_prices(factors, market, credit=scene.has("credit"))
        return values / np.concatenate([np.asarray(prices)[:len(market.asset_names) - 1],
                                        np.asarray(factors["equity_levels"])])
    mix = DEFAULT_MIX if assets.mix is None else assets.mix
    return holdings_at_funding_ratio(factors, market, assets.initial_funding_ratio, mix, fund.schedule,
                                     indexed_share(fund.config, scene), credit=scene.has("credit"))


def load_fund(path: str | os.PathLike) -> Fund:
    """Read a fund file and the liability CSV it names (docs/alm.md, "A fund in files").

    **Raises:** `InputError` naming the file, the line, the field, its value and what is
    allowed, before anything is compiled."""
    path = pathlib.Path(path)
    where = f"fund file {path}"
    text = read_text(path, "fund")
    spec = validate(FundFile, strict_yaml(text, where), where, text)
    market = _market(spec.market, spec.assets, where)
    equities = spec.market.equities
    factors = dict(key_rates=np.asarray(spec.market.key_rates, float),
                   rate_vols=np.asarray(spec.market.rate_vols, float),
                   equity_levels=np.array([e.level for e in equities]),
                   equity_vols=np.array([e.volatility for e in equities]),
                   inflation=np.array(spec.market.inflation), inflation_vol=np.array(spec.market.inflation_vol),
                   spread=np.array(spec.market.spread), spread_vol=np.array(spec.market.spread_vol))
    for group in ("key_rates", "rate_vols"):
        if factors[group].shape != (market.n_tenors,):
            raise InputError(f"{where}: market.{group} has {factors[group].size} entries; expected one per key tenor "
                             f"({market.n_tenors}).")
    liability_path = path.parent / spec.liabilities.file
    liabilities = load_liabilities(liability_path, spec.liabilities.cash_flow_unit,
                                   valuation_date=spec.liabilities.valuation_date)
    factors["liability_cash_flows"] = liabilities.cash_flows
    effects = None if spec.effects is None else tuple(spec.effects)
    try:
        config = ALMConfig(**{k: v for k, v in spec.objective.model_dump().items() if v is not None})
        EFFECTS.scene(effects)
        board = BoardSettings(spec.board.required_funding_ratio,
                              None if spec.board.months is None else tuple(spec.board.months), spec.board.confidence)
        late = [m for m in spec.board.months or () if m > spec.horizon_months]
        if late:
            raise InputError(f"board.months {late} lie beyond horizon_months = {spec.horizon_months}.")
    except InputError as error:
        raise InputError(f"{where}: {error}") from None
    _check_assets(spec.assets, market, where)
    return Fund(spec.name, market, factors, liabilities.schedule, config, spec.horizon_months, effects, spec.assets,
                board, (path, liability_path))


def sample_fund_path() -> pathlib.Path:
    """The built-in fund's file (N = 100 risk factors; its liabilities in `alm_liabilities.csv`)."""
    return pathlib.Path(str(files("finance") / "data" / "alm_fund.yaml"))
