# main.py: thin on purpose (it must stay a .py file; the application is device/app.py or .mpy).
# boot.py has already driven the pyro outputs low. Ctrl-C here returns to the REPL while the board
# is disarmed; in flight mode Ctrl-C is disabled.
from device import app

app.main()
