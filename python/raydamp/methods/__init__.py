"""How raydamp steps: catalogue.py (the methods, tableaux and compositions the compiled core
ships, with their orders) and user_tableau.py (a user's Butcher tableau, checked and registered)."""
