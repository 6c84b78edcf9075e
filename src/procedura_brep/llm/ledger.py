"""Accounting: tokens, cached tokens, calls and cost per role, and the ``--max-cost`` cap.

Prices are data (``prices.toml`` next to this module, extended by a file named in
``PROCEDURA_BREP_PRICES``). A call whose model has no price has an unknown cost (``None``), never
zero, except for providers that spend no money (tapes, exchange, local servers). With a cap set,
a paid model without a price is a configuration error: the cap could not be enforced.
"""

from __future__ import annotations

import os
import threading
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from .errors import BudgetExceeded, ConfigError
from .messages import Usage

__all__ = ["ENV_PRICES", "Ledger", "Price", "PriceTable", "RoleStats"]

ENV_PRICES = "PROCEDURA_BREP_PRICES"
_PACKAGED = Path(__file__).with_name("prices.toml")


@dataclass(frozen=True)
class Price:
    """USD per million tokens."""

    input: float
    cached_input: float
    output: float

    def cost(self, usage: Usage) -> float:
        """Cost of one call in USD (cached input at the cached price)."""
        fresh = max(0, usage.input_tokens - usage.cached_input_tokens)
        return (
            fresh * self.input
            + usage.cached_input_tokens * self.cached_input
            + usage.output_tokens * self.output
        ) / 1e6


FREE = Price(0.0, 0.0, 0.0)


class PriceTable:
    """Model prices keyed by ``provider:model``.

    Args:
        prices: The table; default the packaged one plus ``PROCEDURA_BREP_PRICES``.
    """

    def __init__(self, prices: dict[str, Price] | None = None) -> None:
        self.prices = dict(prices) if prices is not None else self.load_default()

    @staticmethod
    def read(path: str | Path) -> dict[str, Price]:
        """Read a prices TOML file.

        Raises:
            ConfigError: Unreadable file or a bad entry.
        """
        try:
            data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
            return {
                k: Price(float(v["input"]), float(v.get("cached_input", v["input"])), float(v["output"]))
                for k, v in data.items()
            }
        except (OSError, tomllib.TOMLDecodeError, KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"prices file {path}: {exc}") from None

    @classmethod
    def load_default(cls) -> dict[str, Price]:
        """The packaged table updated with the file named by ``PROCEDURA_BREP_PRICES``."""
        prices = cls.read(_PACKAGED)
        extra = os.environ.get(ENV_PRICES)
        if extra:
            prices.update(cls.read(extra))
        return prices

    def lookup(self, model: str) -> Price | None:
        """The price of ``model``: exact key, else the longest key it extends with ``-``."""
        if model in self.prices:
            return self.prices[model]
        matches = [k for k in self.prices if model.startswith(k + "-")]
        return self.prices[max(matches, key=len)] if matches else None


@dataclass
class RoleStats:
    """Totals for one role; ``cost_usd`` is ``None`` once any call had an unknown price."""

    calls: int = 0
    input_tokens: int = 0
    cached_input_tokens: int = 0
    output_tokens: int = 0
    cost_usd: float | None = 0.0


class Ledger:
    """Counts calls, tokens and cost per role and enforces the cost cap.

    Args:
        prices: Price table (default: packaged + ``PROCEDURA_BREP_PRICES``).
        max_cost_usd: Stop before starting a call once this much is spent.
    """

    def __init__(self, *, prices: PriceTable | None = None, max_cost_usd: float | None = None) -> None:
        if max_cost_usd is not None and max_cost_usd < 0:
            raise ConfigError(f"--max-cost must be >= 0, got {max_cost_usd}")
        self.prices = prices or PriceTable()
        self.max_cost_usd = max_cost_usd
        self.by_role: dict[str, RoleStats] = {}
        self.spent_usd = 0.0
        self.unknown_cost_calls = 0
        self._lock = threading.Lock()

    def price_for(self, model: str, *, free: bool = False) -> Price | None:
        """The price used for ``model``; free providers without a price cost zero."""
        price = self.prices.lookup(model)
        return FREE if price is None and free else price

    def validate(self, model: str, *, free: bool = False) -> None:
        """Check the cap can be enforced for ``model``.

        Raises:
            ConfigError: A cap is set and the model has no price.
        """
        if self.max_cost_usd is not None and self.price_for(model, free=free) is None:
            raise ConfigError(
                f"--max-cost is set but there is no price for {model}; add it to a prices TOML "
                f"file named by {ENV_PRICES}, or drop --max-cost"
            )

    def check_budget(self, model: str, *, role: str = "", free: bool = False) -> None:
        """Call before starting a model call.

        Raises:
            BudgetExceeded: The cap is already reached; the call must not start.
            ConfigError: A cap is set and the model has no price.
        """
        self.validate(model, free=free)
        if self.max_cost_usd is not None and self.spent_usd >= self.max_cost_usd:
            raise BudgetExceeded(self.spent_usd, self.max_cost_usd, role=role)

    def record(self, role: str, model: str, usage: Usage, *, free: bool = False) -> float | None:
        """Add one finished call.

        Returns:
            The cost of the call in USD, or ``None`` when the price is unknown.
        """
        price = self.price_for(model, free=free)
        cost = price.cost(usage) if price is not None else None
        with self._lock:
            s = self.by_role.setdefault(role, RoleStats())
            s.calls += 1
            s.input_tokens += usage.input_tokens
            s.cached_input_tokens += usage.cached_input_tokens
            s.output_tokens += usage.output_tokens
            if cost is None:
                s.cost_usd = None
                self.unknown_cost_calls += 1
            else:
                self.spent_usd += cost
                if s.cost_usd is not None:
                    s.cost_usd += cost
        return cost

    @property
    def calls(self) -> int:
        """Total number of recorded calls."""
        return sum(s.calls for s in self.by_role.values())

    @property
    def total_cost_usd(self) -> float | None:
        """Total cost, or ``None`` when some call had an unknown price."""
        return None if self.unknown_cost_calls else self.spent_usd

    def total(self) -> RoleStats:
        """Totals over all roles."""
        t = RoleStats(cost_usd=self.total_cost_usd)
        for s in self.by_role.values():
            t.calls += s.calls
            t.input_tokens += s.input_tokens
            t.cached_input_tokens += s.cached_input_tokens
            t.output_tokens += s.output_tokens
        return t

    def summary(self) -> dict[str, Any]:
        """Plain data for ``report.json``: per role, total and cap."""
        return {
            "roles": {r: asdict(s) for r, s in sorted(self.by_role.items())},
            "total": asdict(self.total()),
            "max_cost_usd": self.max_cost_usd,
        }
