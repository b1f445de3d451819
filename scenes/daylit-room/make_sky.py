# Makes sky.exr, the sky of daylit-room.xml: 512 x 256 latitude-longitude, a blue
# gradient above the horizon, brown ground below, a sun 30 degrees high (radiance
# 2250, 10 texels). Run with a Python that has numpy and mitsuba (not needed to render).
import numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
W,H=512,256
img=np.zeros((H,W,3),np.float32)
v=(np.arange(H)+0.5)/H; theta=v*np.pi
for j in range(H):
    t=theta[j]
    if t<np.pi/2:
        e=np.cos(t)  # elevation sine
        sky=np.array([0.35,0.55,1.0])*(0.6+0.6*e)+np.array([0.6,0.6,0.55])*(1-e)**3
        img[j,:,:]=sky*0.8
    else:
        img[j,:,:]=np.array([0.12,0.1,0.08])
# sun: elevation 30 deg, at u=0.25
su,sv=0.25,(90-30)/180
for j in range(H):
    for i in range(W):
        du=((i+0.5)/W-su)*2*np.pi*np.sin(sv*np.pi); dv=((j+0.5)/H-sv)*np.pi
        if du*du+dv*dv < (0.6*np.pi/180)**2*4:
            img[j,i,:]=np.array([9000,8000,6500],np.float32)/4
mi.Bitmap(img).write('sky.exr')  # beside this script
print(img.max(), (img>100).sum()/3)
