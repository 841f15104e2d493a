"""What differs between two rides of one wheel, and its report."""
