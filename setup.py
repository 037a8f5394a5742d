from glob import glob

from setuptools import find_packages, setup

package_name = "g1_mode_manager"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(include=[package_name, package_name + ".*"])
    + find_packages("sim", include=["g1_sim", "g1_sim.*"]),
    package_dir={"g1_sim": "sim/g1_sim"},
    # the operator console's page, inlined into one response at start
    package_data={"g1_mode_manager.console": ["static/*.html", "static/*.css", "static/*.js"],
                  "g1_mode_manager.policy": ["configs/*.yaml"]},  # the built-in policies' deploy configs
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
        ("share/" + package_name + "/launch", glob("launch/*.launch.py")),
    ],
    install_requires=["setuptools"],
    zip_safe=False,
    maintainer="g1_mode_manager developers",
    maintainer_email="dev@g1-mode-manager.invalid",
    description="Safe control-mode manager for the Unitree G1, with a MuJoCo G1 that speaks Unitree SDK2.",
    license="BSD-3-Clause",
    python_requires=">=3.11",
    entry_points={
        "console_scripts": [
            "mode_manager = g1_mode_manager.node.main:main",
            "g1ctl = g1_mode_manager.cli.main:main",
            "console = g1_mode_manager.console.main:main",
            "g1_demo = g1_mode_manager.demo:main",
            "sim_bridge = g1_sim.bridge.main:main",
        ],
    },
)
