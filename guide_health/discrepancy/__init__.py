"""Model-versus-measurement discrepancy workflow."""
