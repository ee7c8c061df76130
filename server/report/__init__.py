"""The device report card (issue 38, docs/report-card.md): `viestac report devices DATA --out DIR`."""
