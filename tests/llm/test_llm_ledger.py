"""Accounting and the cost cap."""

from __future__ import annotations

import pytest

from procedura_brep.llm import (
    BudgetExceeded,
    Client,
    ConfigError,
    Ledger,
    Price,
    PriceTable,
    ScriptedProvider,
    Usage,
)


def test_cost_uses_cached_price():
    ledger = Ledger()
    cost = ledger.record("plan", "openai:gpt-4o", Usage(1_000_000, 400_000, 100_000))
    assert cost == pytest.approx(0.6 * 2.50 + 0.4 * 1.25 + 0.1 * 10.0)
    assert ledger.by_role["plan"].calls == 1 and ledger.total_cost_usd == pytest.approx(cost)


def test_dated_snapshot_uses_base_price_and_unknown_is_none():
    table = PriceTable()
    assert table.lookup("anthropic:claude-sonnet-4-5-20250929") == table.lookup("anthropic:claude-sonnet-4-5")
    assert table.lookup("openai:no-such-model") is None
    ledger = Ledger()
    assert ledger.record("build", "openai:no-such-model", Usage(10, 0, 10)) is None
    ledger.record("plan", "openai:gpt-4o", Usage(10, 0, 10))
    assert ledger.by_role["build"].cost_usd is None and ledger.by_role["plan"].cost_usd > 0
    assert ledger.total_cost_usd is None and ledger.spent_usd > 0
    assert ledger.record("x", "openai:no-such-model", Usage(10), free=True) == 0.0
    summary = ledger.summary()
    assert summary["total"]["calls"] == 3 and summary["total"]["cost_usd"] is None


def test_max_cost_stops_before_the_next_call():
    prices = PriceTable({"scripted:paid": Price(1_000_000.0, 0.0, 0.0)})  # $1 per input token
    provider = ScriptedProvider("paid", replies=["a", "b", "c"], usage=Usage(input_tokens=1))
    provider.free = False
    client = Client(provider, ledger=Ledger(prices=prices, max_cost_usd=1.5))
    assert client.ask("plan", 0, "s", "x").cost_usd == pytest.approx(1.0)
    assert client.ask("build", 1, "s", "x").text == "b"  # $1 spent < $1.5: allowed
    with pytest.raises(BudgetExceeded, match=r"before the 'critic' call: spent \$2.0000 of --max-cost \$1.5000"):
        client.ask("critic", 2, "s", "x")
    assert provider.remaining == 1  # the call never started
    assert client.ledger.calls == 2


def test_max_cost_with_unknown_price_is_a_config_error():
    provider = ScriptedProvider("paid")
    provider.free = False
    with pytest.raises(ConfigError, match="no price for scripted:paid"):
        Client(provider, ledger=Ledger(max_cost_usd=1.0))
    with pytest.raises(ConfigError, match=">= 0"):
        Ledger(max_cost_usd=-1)


def test_free_providers_work_with_a_cap():
    client = Client(ScriptedProvider(replies=["a"]), ledger=Ledger(max_cost_usd=0.01))
    assert client.ask("plan", 0, "", "x").cost_usd == 0.0


def test_prices_file_override(tmp_path, monkeypatch):
    extra = tmp_path / "prices.toml"
    extra.write_text('["openai:llama3"]\ninput = 0\noutput = 0\n\n["openai:gpt-4o"]\ninput = 1\ncached_input = 1\noutput = 1\n')
    monkeypatch.setenv("PROCEDURA_BREP_PRICES", str(extra))
    table = PriceTable()
    assert table.lookup("openai:llama3") == Price(0, 0, 0)
    assert table.lookup("openai:gpt-4o") == Price(1, 1, 1)
    extra.write_text("oops = [")
    with pytest.raises(ConfigError, match="prices file"):
        PriceTable()
