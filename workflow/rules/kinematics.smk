rule kinematics:
    message:
        "Shaft speeds, gear-mesh frequencies and orders (Table 2)"
    input:
        code=code("kinematics.py"),
    params:
        gearbox={"stages": config["gearbox"]["stages"], "name": config["gearbox"]["name"]},
        hss_rpm=config["campaign"]["nominal"]["speed_rpm"],
    output:
        nc=f"{RESULTS}/kinematics/frequencies.nc",
        table=f"{RESULTS}/tables/table2.csv",
    log:
        f"{RESULTS}/logs/kinematics.log",
    benchmark:
        f"{RESULTS}/benchmarks/kinematics.tsv"
    threads: DECLARED.threads("kinematics")
    resources:
        **DECLARED.resources("kinematics"),
    script:
        "../scripts/kinematics.py"
