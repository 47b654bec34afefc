"""The symbolic checks of the seed paper's claims (derivations/)."""


rule derivations:
    input:
        DERIVATION_CODE,
    output:
        claims="results/derivations/claims.json",
        report="results/derivations/report.md",
    log:
        "results/logs/derivations.log",
    shell:
        "{PYTHON} -m derivations.paper.report --out results/derivations > {log} 2>&1"
