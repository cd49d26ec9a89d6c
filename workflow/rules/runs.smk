# A study: one Snakemake module per run of `runs:` (gbpipe.config.runs), each the main
# Snakefile evaluated again with that run's validated config, whose `results:` is
# <results>/<name>. Its rules are renamed <name>_<rule>, so the whole study is one DAG
# that `-j` or a cluster spreads; a run's outputs and logs are in its own folder.
# (The `module`/`use rule` statements take literal names, so the loop calls the
# workflow API they compile to.)


def _use_run(name, cfg):
    workflow.module(name=name, snakefile=workflow.main_snakefile, config=cfg)
    workflow.userule(rules=["*"], from_module=name, exclude_rules=[],
                     name_modifier=f"{name}_*", lineno=1)(lambda: None)


for _name, _cfg in RUNS.items():
    _use_run(_name, _cfg)


def run_targets():
    """Final files of every run (its own `all` rule's input)."""
    return [getattr(rules, f"{name}_all").input for name in RUNS]
