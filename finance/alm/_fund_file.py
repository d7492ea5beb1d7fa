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

import os
import pathlib
from importlib.resources import files
from typing import NamedTuple

import numpy as np

from snapo_ode import MAX_YAML_BYTES, InputError, line_of, read_text, strict_yaml, validate

from ._board import BoardSettings
from ._factors import DEFAULT_MIX, check_market_ranges, holdings_at_funding_ratio, units_held
from ._liabilities import LiabilitySchedule
from ._liability_file import load_liabilities
from ._market import ASSETS, AssetClass, Market, check_asset_classes
from ._model import EFFECTS, ALMConfig, indexed_share
from ._fund_schema import AssetsSection, FundFile, MarketSection
from ._units import in_millions

class Fund(NamedTuple):
    """A fund ready to study (`build_fund_study`): its `name`, `market`, every factor group but
    the holdings `factors` (float64 arrays), the liability `schedule`, the `config`,
    `horizon_months`, the `effects` it names (None: all), its `assets` section (the holdings
    follow from it once the study's initial market and effects are known: `fund_holdings`), its
    `board` settings, the `files` it was read from (the fund file, then the liability file;
    reports record their SHA-256), its `currency` and its `strategic_mix` (class -> weight, in
    the market's class order; None where the file names none)."""

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
    currency: str = "EUR"
    strategic_mix: dict[str, float] | None = None


class _Locator:
    """Where a field of the fund file is: `at("assets.mix")` gives "fund file F, line N" (the
    first line that holds the field's last key)."""

    def __init__(self, where: str, text: str):
        self.where, self.text = where, text

    def at(self, field: str) -> str:
        return f"{self.where}{line_of(self.text, field.split('.'))}"


def _keys(file: _Locator, field: str, given: dict, allowed: tuple[str, ...]) -> None:
    unknown = [key for key in given if key not in allowed]
    missing = [key for key in allowed if key not in given]
    if unknown or missing:
        raise InputError(f"{file.at(field)}: {field} has {'unknown ' + repr(unknown) if unknown else ''}"
                         f"{' and ' if unknown and missing else ''}{'no ' + repr(missing) if missing else ''}; "
                         f"its keys are {', '.join(allowed)}.")


def _market(section: MarketSection, assets: AssetsSection, file: _Locator) -> Market:
    classes = None if assets.classes is None else tuple(
        AssetClass(c.name, c.kind, c.maturity if c.duration is None else c.duration) for c in assets.classes)
    both = {"bond_maturities", "inflation_linked_maturity", "credit_maturity"} & assets.model_fields_set
    if classes is not None and both:
        raise InputError(f"{file.at('classes')}: assets.{sorted(both)[0]} with assets.classes: the classes carry their own "
                         "maturities; give one of the two.")
    try:
        names = ASSETS if classes is None else tuple(c.name for c in check_asset_classes(classes))
    except InputError as error:
        raise InputError(f"{file.at('classes')}: assets.classes: {error}") from None
    bounds = {}
    if assets.weight_bounds is not None:
        _keys(file, "assets.weight_bounds", assets.weight_bounds, names)
        bounds = dict(weight_low=tuple(assets.weight_bounds[a][0] for a in names),
                      weight_high=tuple(assets.weight_bounds[a][1] for a in names))
    if section.correlation is not None and len({len(row) for row in section.correlation}) > 1:
        raise InputError(f"{file.at('correlation')}: market.correlation has rows of "
                         f"{sorted({len(row) for row in section.correlation})} entries; every row has one per risk driver.")
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
        field = str(error).split(" ", 1)[0].split("[", 1)[0]
        raise InputError(f"{file.at(field)}: {error}") from None


def _check_assets(assets: AssetsSection, market: Market, file: _Locator, currency: str) -> None:
    if (assets.holdings is None) == (assets.initial_funding_ratio is None):
        raise InputError(f"{file.at('assets')}: assets needs exactly one of initial_funding_ratio (with mix) and "
                         "holdings.")
    if assets.holdings is not None:
        _keys(file, "assets.holdings", assets.holdings, (*market.asset_names[:-1], *market.equity_names))
        if assets.mix is not None:
            raise InputError(f"{file.at('assets.mix')}: assets.mix with assets.holdings: holdings fix the mix; give "
                             "one of the two.")
        in_millions(assets.holdings_unit, f"{file.at('holdings_unit')}: assets.holdings_unit", currency)
        return
    mix = DEFAULT_MIX if assets.mix is None else assets.mix
    if assets.mix is None and market.asset_names != ASSETS:
        raise InputError(f"{file.at('assets')}: assets.mix is needed for the asset classes {list(market.asset_names)}.")
    _keys(file, "assets.mix", mix, market.asset_names)
    if min(mix.values()) < 0 or abs(sum(mix.values()) - 1.0) > 1e-9:
        raise InputError(f"{file.at('assets.mix')}: assets.mix = {mix}; allowed: weights >= 0 summing to 1.")
    if not 0.0 < assets.initial_funding_ratio <= 10.0:
        raise InputError(f"{file.at('initial_funding_ratio')}: assets.initial_funding_ratio = "
                         f"{assets.initial_funding_ratio}; allowed: (0, 10].")


def fund_holdings(fund: Fund, factors: dict, scene) -> np.ndarray:
    """The units the fund holds (`holdings`), from its `assets` section: its holdings' money
    values at the initial prices, or its initial funding ratio and mix, the liabilities valued as
    the simulation values them under `scene` on the initial market of `factors`."""
    assets, market = fund.assets, fund.market
    if assets.holdings is not None:
        names = (*market.asset_names[:-1], *market.equity_names)
        values = np.array([assets.holdings[name] for name in names]) * in_millions(
            assets.holdings_unit, "holdings_unit", fund.currency)
        return units_held(values, factors, market, scene.has("credit"))
    mix = DEFAULT_MIX if assets.mix is None else assets.mix
    return holdings_at_funding_ratio(factors, market, assets.initial_funding_ratio, mix, fund.schedule,
                                     indexed_share(fund.config, scene), credit=scene.has("credit"))


def load_fund(path: str | os.PathLike) -> Fund:
    """Read a fund file and the liability CSV it names (docs/alm.md, "A fund in files").

    **Raises:** `InputError` naming the file, the line, the field, its value and what is
    allowed, before anything is compiled."""
    path = pathlib.Path(path)
    where = f"fund file {path}"
    text = read_text(path, "fund", MAX_YAML_BYTES)
    spec = validate(FundFile, strict_yaml(text, where), where, text)
    file = _Locator(where, text)
    market = _market(spec.market, spec.assets, file)
    equities = spec.market.equities
    factors = dict(key_rates=np.asarray(spec.market.key_rates, float),
                   rate_vols=np.asarray(spec.market.rate_vols, float),
                   equity_levels=np.array([e.level for e in equities]),
                   equity_vols=np.array([e.volatility for e in equities]),
                   inflation=np.array(spec.market.inflation), inflation_vol=np.array(spec.market.inflation_vol),
                   spread=np.array(spec.market.spread), spread_vol=np.array(spec.market.spread_vol))
    for group in ("key_rates", "rate_vols"):
        if factors[group].shape != (market.n_tenors,):
            raise InputError(f"{file.at(group)}: market.{group} has {factors[group].size} entries; expected one per key "
                             f"tenor ({market.n_tenors}).")
    _check_market_factors(factors, file)
    liability_path = path.parent / spec.liabilities.file
    try:
        liabilities = load_liabilities(liability_path, spec.liabilities.cash_flow_unit,
                                       valuation_date=spec.liabilities.valuation_date, currency=spec.currency)
    except InputError as error:
        if "liabilities.cash_flow_unit" not in str(error):
            raise
        raise InputError(f"{file.at('cash_flow_unit')}: {error}") from None
    factors["liability_cash_flows"] = liabilities.cash_flows
    effects = None if spec.effects is None else tuple(spec.effects)
    try:
        config = ALMConfig(**{k: v for k, v in spec.objective.model_dump().items() if v is not None})
    except InputError as error:
        field = str(error).split(" ", 1)[0]
        raise InputError(f"{file.at('objective.' + field)}: objective.{error}") from None
    try:
        EFFECTS.scene(effects)
    except InputError as error:
        raise InputError(f"{file.at('effects')}: effects: {error}") from None
    late = [m for m in spec.board.months or () if m > spec.horizon_months]
    try:
        if late:
            raise InputError(f"board.months {late} lie beyond horizon_months = {spec.horizon_months}.")
        board = BoardSettings(spec.board.required_funding_ratio,
                              None if spec.board.months is None else tuple(spec.board.months), spec.board.confidence)
    except InputError as error:
        raise InputError(f"{file.at('board')}: {error}") from None
    _check_assets(spec.assets, market, file, spec.currency)
    return Fund(spec.name, market, factors, liabilities.schedule, config, spec.horizon_months, effects, spec.assets,
                board, (path, liability_path), spec.currency, _strategic_mix(spec.assets.strategic_mix, market, file))


def _strategic_mix(given: dict | None, market: Market, file: _Locator) -> dict[str, float] | None:
    """The strategic mix in the market's class order, or None; refused (with the line) unless it
    has every class once, weights in [0, 1] summing to 1 (to 1e-9)."""
    if given is None:
        return None
    _keys(file, "assets.strategic_mix", given, market.asset_names)
    weights = [given[name] for name in market.asset_names]
    if min(weights) < 0 or max(weights) > 1 or abs(sum(weights) - 1.0) > 1e-9:
        raise InputError(f"{file.at('assets.strategic_mix')}: assets.strategic_mix = {given} (sum {sum(weights):.12g}); "
                         "allowed: a weight in [0, 1] per asset class, summing to 1.")
    return {name: float(given[name]) for name in market.asset_names}


_FILE_KEYS = dict(equity_vols="volatility", equity_levels="level")  # a factor group's key in the file


def _check_market_factors(factors: dict, file: _Locator) -> None:
    """The market groups' ranges (`check_market_ranges`, as the model checks them), named as the
    file names them, with the line."""
    try:
        check_market_ranges(factors)
    except InputError as error:
        group = str(error).split(" ", 1)[0].split("[", 1)[0]
        raise InputError(f"{file.at(_FILE_KEYS.get(group, group))}: market.{error}") from None


def sample_fund_path() -> pathlib.Path:
    """The built-in fund's file (N = 100 risk factors; its liabilities in `alm_liabilities.csv`)."""
    return pathlib.Path(str(files("finance") / "data" / "alm_fund.yaml"))
