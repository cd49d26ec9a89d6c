rule kinematics:
    message:
        "Shaft speeds, gear-mesh frequencies and orders (Table 2)"
    input:
        lib("kinematics.py", "io.py", "tables.py"),
    params:
        gearbox={"stages": config["gearbox"]["stages"], "name": config["gearbox"].get("name", "")},
        hss_rpm=config.get("campaign", {}).get("nominal", {}).get("speed_rpm", 1120.0),
    output:
        nc=f"{RESULTS}/kinematics/frequencies.nc",
        table=f"{RESULTS}/tables/table2.csv",
    log:
        f"{RESULTS}/logs/kinematics.log",
    benchmark:
        f"{RESULTS}/benchmarks/kinematics.tsv"
    script:
        "../scripts/kinematics.py"
