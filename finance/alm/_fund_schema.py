"""The fund file's schema (pydantic, strict): its sections, their fields and types. Ranges and
the rules between fields are checked by `_fund_file.load_fund` and the model's own checks."""


import pydantic

from snapo_ode import STRICT_SCHEMA, FiniteNumber, IsoDate

from ._model import MAX_HORIZON_MONTHS

Numbers = list[FiniteNumber]
CurrencyCode = pydantic.constr(pattern=r"^[A-Z]{3}$")  # ISO 4217 style: EUR, USD, ...
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
    valuation_date: IsoDate | None = None


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
    1), or `holdings`, each asset's market value (cash, each non-equity class and each equity
    index by name) in `holdings_unit`. `strategic_mix` (optional): the fund's strategic asset
allocation, a weight per asset class summing to 1, held by monthly rebalancing as the first
baseline the policy is compared with. The funding ratio values the liabilities as the
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
    strategic_mix: dict[str, FiniteNumber] | None = None


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
    currency: CurrencyCode = "EUR"
    horizon_months: pydantic.conint(strict=True, ge=1, le=MAX_HORIZON_MONTHS) = 120
    effects: list[str] | None = None
    market: MarketSection
    liabilities: LiabilitiesSection
    assets: AssetsSection
    objective: ObjectiveSection = ObjectiveSection()
    board: BoardSection = BoardSection()
