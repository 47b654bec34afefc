"""The scenario table beside the seed paper's printed values."""

import json


rule scenario_table:
    input:
        summaries=expand("results/scenarios/{scenario}/summary.json", scenario=SCENARIOS),
        trajectories=expand("results/scenarios/{scenario}/trajectory.csv", scenario=SCENARIOS),
        scenarios=[SCENARIO_FILES[s] for s in SCENARIOS],
        claims="results/derivations/claims.json",
        script=SCRIPTS / "tables.py",
        helpers=closure(SCRIPTS / "tables.py"),
    output:
        csv="results/tables/scenarios.csv",
        md="results/tables/scenarios.md",
    params:
        dirs=expand("results/scenarios/{scenario}", scenario=SCENARIOS),
        paper_keys=json.dumps(config.get("paper_keys", {})),
    shell:
        "{PYTHON} {input.script} --results {params.dirs} --scenarios {input.scenarios}"
        " --claims {input.claims} --paper-keys '{params.paper_keys}' --csv {output.csv} --md {output.md}"
