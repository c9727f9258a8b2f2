"""Build script of the pd_console ament_python package."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'pd_console'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/console', glob('console/*')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Pseudo-dynamic testing maintainers',
    maintainer_email='maintainers@pseudodynamic.dev',
    description=('The live test console: a web page to watch a running or finished test, log '
                 'in with the printed token, steer it and stop it.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'console = pd_console.console:main',
        ],
        'pd.commands': [
            'console = pd_console.commands:CONSOLE',
        ],
    },
)
