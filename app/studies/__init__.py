"""Studies on the simulated system: the paper's reproduction (`reproduce`, with its `figures`),
the calibration methods compared (`calibration_methods`), and the claim that learning
compensates calibration error (`compensation`)."""
