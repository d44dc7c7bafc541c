"""The package's Python tools: the demo's reports, the experiments' runs and summaries, the test
run's summary and the rostests' process helpers. Run a tool as `python3 -m ccir_mapping.<name>`
once the workspace is sourced; the generated messages live beside them (ccir_mapping.msg)."""
