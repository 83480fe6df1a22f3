"""The material-domain route: sample a domain of material and particle-size parameters once
(``campaign``), fit global metamodels of its responses (``metamodel``), and calibrate
materials on them without simulating (Richter & Will 2021)."""
