"""One ride as its reader sees it: summary, rider view, drivetrain report, residual and HTML page."""
