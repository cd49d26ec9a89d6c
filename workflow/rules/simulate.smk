# library modules of the simulator (inputs of both simulation rules: editing them reruns)
SIM_LIB = lib("simulate/campaign.py", "simulate/profiles.py", "simulate/lsim.py",
              "simulate/tacho.py", "model/__init__.py", "model/statespace.py",
              "model/drivetrain.py", "model/mechanics.py", "io.py")


rule simulate:
    message:
        "Closed-loop test {wildcards.test} ({wildcards.profile} steps), clean and measured-like"
    input:
        SIM_LIB,
    params:
        cfg={k: config[k] for k in ("seed", "gearbox", "bench", "campaign", "noise",
                                    "excitation", "tachometer")},
    output:
        f"{RESULTS}/simulate/{{test}}_{{profile}}.nc",
    log:
        f"{RESULTS}/logs/simulate/{{test}}_{{profile}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/simulate/{{test}}_{{profile}}.tsv"
    resources:
        mem_mb=2000,
    script:
        "../scripts/simulate.py"


rule sweep:
    message:
        "Speed sweep at constant torque with harmonics and tachometer pulses"
    input:
        SIM_LIB,
    params:
        cfg={k: config[k] for k in ("seed", "gearbox", "bench", "campaign", "noise",
                                    "excitation", "tachometer", "sweep")},
    output:
        f"{RESULTS}/sweep/sweep.nc",
    log:
        f"{RESULTS}/logs/sweep.log",
    benchmark:
        f"{RESULTS}/benchmarks/sweep.tsv"
    resources:
        mem_mb=4000,
    script:
        "../scripts/sweep.py"


rule figures_tests:
    message:
        "Figures 7-10: speed and torque vs time in the speed- and torque-ramp tests"
    input:
        speed=expand(f"{RESULTS}/simulate/speed_{{d}}_{{p}}.nc", d=["up", "down"],
                     p=config["figures"]["test_profile"]),
        torque=expand(f"{RESULTS}/simulate/torque_{{d}}_{{p}}.nc", d=["up", "down"],
                      p=config["figures"]["test_profile"]),
        code=lib("figures/time_plots.py", "figures/style.py"),
    output:
        [f for n in (7, 8, 9, 10) for f in figure_outputs(n, "Test campaigns")],
    log:
        f"{RESULTS}/logs/figures_tests.log",
    script:
        "../scripts/figures_tests.py"
