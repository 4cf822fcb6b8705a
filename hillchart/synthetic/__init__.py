"""Physically based synthetic turbines (Francis family, bulb) and the charts digitized from them."""
